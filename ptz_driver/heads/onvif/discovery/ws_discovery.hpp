// WS-Discovery's probe on UDP (the 2005/04 version ONVIF uses): the Probe (requests.hpp) sent to
// 239.255.255.250:3702, the ProbeMatches that come back collected for a while and read by
// parseProbeMatches (device_replies.hpp). Every datagram is outside bytes: its size is bounded
// (a larger one is dropped unread), a reply relating to another message is dropped, and each
// drop is counted by reason. No LCM, no threads: one poll loop until the timeout.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ptz_driver/heads/onvif/device_replies.hpp"
#include "ptz_driver/heads/onvif/soap.hpp"

namespace ptz::onvif {

constexpr const char* kDiscoveryGroup = "239.255.255.250";
constexpr int kDiscoveryPort = 3702;

struct DiscoveryOptions {
  int timeout_ms = 2000;  // how long replies are collected after the Probe went out
  int ttl = 1;            // multicast TTL: 1 stays on the local network, as WS-Discovery wants
  // IPv4 address of the interface the Probe leaves by; empty: the routing table's choice.
  std::string interface_address;
  std::size_t max_reply_bytes = 32 * 1024;  // a ProbeMatches is a few kB; larger is dropped
  std::size_t max_replies = 256;            // datagrams read at most (a flood ends the wait)
  std::size_t max_devices = kMaxListItems;  // distinct endpoints kept at most
  // Where the Probe goes: WS-Discovery's group; tests may aim at a unicast address.
  std::string group = kDiscoveryGroup;
  int port = kDiscoveryPort;
};

struct DiscoveryCounters {
  int64_t replies = 0;           // datagrams received
  int64_t matches = 0;           // ProbeMatch entries read (duplicates included)
  int64_t duplicates = 0;        // an endpoint already found (another interface, a repeat)
  int64_t oversize = 0;          // larger than max_reply_bytes: dropped unread
  int64_t wrong_relates_to = 0;  // RelatesTo not our Probe's MessageID
  int64_t malformed = 0;         // not a ProbeMatches that parses
  int64_t beyond_limits = 0;     // past max_replies or max_devices
};

struct DiscoveryResult {
  std::vector<ProbeMatch> devices;  // one per endpoint, in the order they answered
  DiscoveryCounters counters;
  std::vector<std::string> problems;  // the first few drops, each with its sender and reason
  std::string message_id;             // the Probe's
};

// Sends one Probe and collects the answers for options.timeout_ms. An Error when the socket
// cannot be made or the Probe cannot be sent (no route to the group: the error says so); no
// answer at all is an empty list, not an error.
Result<DiscoveryResult> discover(const DiscoveryOptions& options = {});

// The name and hardware of a device's scopes (onvif://www.onvif.org/name/…, …/hardware/…),
// percent-decoded; empty when absent.
std::string scopeValue(const std::vector<std::string>& scopes, const std::string& kind);

}  // namespace ptz::onvif
