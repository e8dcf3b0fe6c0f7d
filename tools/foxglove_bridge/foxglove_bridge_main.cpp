// ptz-foxglove-bridge: every LCM channel of the run, converted by ptz::foxglove::Converter (the
// same topics as ptz-mcap's files), served live over the Foxglove WebSocket protocol. It only
// listens: each channel keeps its newest message until the loop hands it over (a queue of one per
// channel), so it never works through a backlog nor slows anyone; a message no connected client
// subscribes to (bridge.hpp) is only counted. The server's thread sends; slow clients lose
// messages, never delay the loop.
#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/transport/channel_regex.hpp"
#include "common/transport/transport.hpp"
#include "tools/foxglove/convert.hpp"
#include "tools/foxglove_bridge/bridge.hpp"

namespace ptz::foxglove_bridge {
namespace {

constexpr int kExitCannotListen = 4;

void declare(Params& p) {
  addTransportParams(p);
  p.add("address", "0.0.0.0",
        "IP address to listen on: 0.0.0.0 every interface (Foxglove on a laptop on the LAN), "
        "127.0.0.1 this host only");
  p.add("port", 8765, "", "TCP port of the WebSocket server (Foxglove's default 8765)",
        Range::between(1, 65535));
  declareRigParams(p);
  p.add("image_rate_hz", 10.0, "Hz", "images (and their calibrations) at most this often (0: all)",
        Range::between(0, 1000));
  p.add("image_max_width_px", 640, "px", "wider images are scaled down, JPEG (0: as they are)",
        Range::between(0, 16384));
  p.add("jpeg_quality", 80, "", "JPEG quality of re-encoded images", Range::between(1, 100));
  p.add("cloud_rate_hz", 1.0, "Hz", "point clouds at most this often (0: all)",
        Range::between(0, 1000));
  p.add("max_clients", 16, "", "more clients are refused", Range::between(1, 1024));
  p.add("send_buffer_limit_kb", 8192, "kB",
        "a client with more than this queued on its socket gets nothing more until it drains",
        Range::between(64, 1048576));
}

// Every channel under the prefix, raw bytes, the newest of each kept until delivered.
class NewestPerChannel : public PendingDelivery {
 public:
  struct Pending {
    std::vector<uint8_t> bytes;
    int64_t receive_utime = 0;
    bool waiting = false;
  };
  using Handler = std::function<void(const std::string& channel, const Pending&)>;

  NewestPerChannel(lcm::LCM& lcm, const std::string& prefix, StatusReporter& status,
                   Handler handler)
      : lcm_(&lcm), prefix_(prefix), status_(status), handler_(std::move(handler)) {
    subscription_ = lcm.subscribeFunction(channelsStartingWith(prefix), &dispatch, this);
    registerPending(lcm_, this);
  }
  ~NewestPerChannel() override {
    unregisterPending(lcm_, this);
    lcm_->unsubscribe(subscription_);
  }
  NewestPerChannel(const NewestPerChannel&) = delete;
  NewestPerChannel& operator=(const NewestPerChannel&) = delete;

  void deliver() override {
    for (auto& [channel, p] : pending_) {
      if (!p.waiting) continue;
      p.waiting = false;
      handler_(channel, p);
    }
  }

 private:
  // At most this many channels are tracked and reported in the status (a hostile sender could
  // invent any number).
  static constexpr size_t kMaxChannels = 256;

  static void dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                       NewestPerChannel* self) {
    auto it = self->pending_.find(channel);
    if (it == self->pending_.end()) {
      if (self->pending_.size() >= kMaxChannels) {
        self->status_.increment("messages_over_channel_limit");
        return;
      }
      it = self->pending_.emplace(channel, Pending{}).first;
    }
    self->status_.countIn(channel, -1);
    Pending& p = it->second;
    if (p.waiting) self->status_.countDropped(channel, "superseded");
    const auto* data = static_cast<const uint8_t*>(rbuf->data);
    p.bytes.assign(data, data + rbuf->data_size);
    p.receive_utime = rbuf->recv_utime;
    p.waiting = true;
  }

  lcm::LCM* lcm_;
  std::string prefix_;
  lcm::Subscription* subscription_ = nullptr;
  StatusReporter& status_;
  Handler handler_;
  std::map<std::string, Pending> pending_;
};

foxglove::ConvertOptions convertOptions(const Params& p) {
  foxglove::ConvertOptions o;
  o.image_rate_hz = p.getDouble("image_rate_hz");
  o.image_max_width_px = p.getInt("image_max_width_px");
  o.jpeg_quality = p.getInt("jpeg_quality");
  o.cloud_rate_hz = p.getDouble("cloud_rate_hz");
  return o;
}

ServerOptions serverOptions(const Params& p) {
  ServerOptions o;
  o.address = p.getString("address");
  o.port = static_cast<uint16_t>(p.getInt("port"));
  o.max_clients = static_cast<size_t>(p.getInt("max_clients"));
  o.send_buffer_limit_bytes = static_cast<size_t>(p.getInt("send_buffer_limit_kb")) * 1024;
  o.metadata = {{"lcm_url", lcmUrl(p)}, {"channel_prefix", p.getString("channel_prefix")}};
  return o;
}

class BridgeNode {
 public:
  BridgeNode(const Params& p, lcm::LCM* lcm, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-foxglove-bridge"),
        prefix_(p.getString("channel_prefix")),
        address_(p.getString("address")),
        server_(serverOptions(p)),
        bridge_(server_, std::move(rig), convertOptions(p), prefix_) {}

  int run() {
    try {
      server_.start();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ptz-foxglove-bridge: %s\n", e.what());
      status_.setState(ptzstereo::process_status_t::STATE_ERROR, e.what());
      status_.publishLast();
      return kExitCannotListen;
    }
    std::fprintf(stderr,
                 "ptz-foxglove-bridge: serving ws://%s:%u (Foxglove: Open connection, "
                 "Foxglove WebSocket)\n",
                 address_.c_str(), server_.port());
    input_ = std::make_unique<NewestPerChannel>(
        *lcm_, prefix_, status_, [this](const std::string& ch, const NewestPerChannel::Pending& m) {
          bridge_.onMessage(ch, m.bytes.data(), m.bytes.size(), m.receive_utime);
        });
    status_.publishNow();  // up and subscribed
    while (!StopFlag::stopRequested()) {
      handleNewest(*lcm_, 100);
      updateCounters();
      status_.maybePublish();
    }
    input_.reset();
    server_.stop();
    updateCounters();
    status_.publishLast();
    return 0;
  }

 private:
  void updateCounters() {
    status_.setCounters(bridge_.counters());
    std::vector<std::string> reasons;
    for (const auto& [channel, n] : bridge_.takeNewDrops(&reasons)) {
      status_.countDropped(channel, "unconvertible", n);
    }
    for (const auto& key : reasons) {
      log_.warn("convert " + key, "ptz-foxglove-bridge: not converted: " + key);
    }
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  std::string prefix_;
  std::string address_;
  Server server_;
  Bridge bridge_;
  std::unique_ptr<NewestPerChannel> input_;
};

}  // namespace
}  // namespace ptz::foxglove_bridge

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-foxglove-bridge",
                "Serves the live LCM traffic (every channel, converted to Foxglove's messages as "
                "ptz-mcap converts a log) over the Foxglove WebSocket protocol: open "
                "ws://HOST:8765 in Foxglove or Lichtblick. Exit 0 stopped, 1 LCM would not open, "
                "2 bad flags, 3 internal error, 4 cannot listen on address:port.");
  foxglove_bridge::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    foxglove_bridge::BridgeNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
