// What ptz-foxglove-bridge does with each LCM message, without LCM: converted (ptz_foxglove) only
// when a connected client subscribes to one of the topics it makes, then published to the
// server; topics the converter adds (a process's first status) advertised as they appear; the
// counters of its status.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "tools/foxglove/convert.hpp"
#include "tools/foxglove_bridge/server.hpp"

namespace ptz::foxglove_bridge {

class Bridge {
 public:
  // prefix: the channel prefix of this rig (the converter knows the contract's plain names).
  Bridge(Server& server, StereoRig rig, const foxglove::ConvertOptions& options,
         std::string prefix);

  // One LCM message of the run (its channel with the prefix).
  void onMessage(const std::string& channel, const void* data, size_t size, int64_t receive_utime);
  // Topics the converter added since, to the server.
  void advertiseNewTopics();

  // The status's counters: the server's, the conversion's (messages_converted, images_converted,
  // messages_not_converted_no_client / _no_subscriber, messages_ignored, converter_dropped,
  // topics). Those of messages appear once non-zero.
  std::map<std::string, int64_t> counters() const;
  // Messages the converter dropped since the last call, by channel (with the prefix); the new
  // "CHANNEL: reason" keys in *new_reasons (to be said on stderr).
  std::map<std::string, int64_t> takeNewDrops(std::vector<std::string>* new_reasons);

 private:
  Server& server_;
  foxglove::Converter converter_;
  std::string prefix_;
  std::vector<uint32_t> channel_ids_;  // by converter topic index
  int64_t converted_ = 0, not_converted_no_client_ = 0;
  std::map<std::string, int64_t> drops_seen_, drops_counted_;
};

}  // namespace ptz::foxglove_bridge
