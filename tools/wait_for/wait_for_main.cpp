// ptz-wait-for: waits until a message arrived on every channel named (e.g. the first status of
// the processes a script started), so scripts start the next step when those are up, not after
// a guessed sleep. Exit 0 when all arrived, 1 on timeout (naming the silent channels).
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>

#include "common/transport/transport.hpp"

namespace {
struct Seen {
  std::set<std::string> channels;
  void on(const lcm::ReceiveBuffer*, const std::string& channel) { channels.insert(channel); }
};
}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-wait-for", "Waits until a message arrived on each of the channels named.");
  ptz::addTransportParams(p);
  p.add("channels", "", "comma-separated channel names (required)");
  p.add("timeout_s", 20.0, "s", "give up after this long", ptz::Range::above(0));
  return ptz::runProcess(argc, argv, p, [](const ptz::Params& params, lcm::LCM& lcm) {
    std::set<std::string> wanted;
    std::stringstream list(params.getString("channels"));
    for (std::string c; std::getline(list, c, ',');) {
      if (!c.empty()) wanted.insert(ptz::channel(params, c));
    }
    if (wanted.empty()) throw ptz::ConfigError("--channels NAME[,NAME...] is required");
    Seen seen;
    for (const auto& c : wanted) lcm.subscribe(c, &Seen::on, &seen);
    const auto deadline =
        std::chrono::steady_clock::now() +
        std::chrono::milliseconds(static_cast<int64_t>(params.getDouble("timeout_s") * 1000));
    while (seen.channels.size() < wanted.size() && !ptz::StopFlag::stopRequested()) {
      if (std::chrono::steady_clock::now() > deadline) {
        std::string missing;
        for (const auto& c : wanted) {
          if (!seen.channels.count(c)) missing += " " + c;
        }
        std::fprintf(stderr, "ptz-wait-for: nothing on%s within %.0f s\n", missing.c_str(),
                     params.getDouble("timeout_s"));
        return 1;
      }
      lcm.handleTimeout(100);
    }
    return 0;
  });
}
