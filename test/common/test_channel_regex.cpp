// A channel prefix full of regex specials, used as an LCM subscription (memq://), matches only
// channels that start with it literally.
#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <string>
#include <vector>

#include "common/transport/channel_regex.hpp"

namespace {

void record(const lcm::ReceiveBuffer*, const std::string& channel, std::vector<std::string>* got) {
  got->push_back(channel);
}

// The channels of sent that a subscription to pattern receives, in order.
std::vector<std::string> received(const std::string& pattern,
                                  const std::vector<std::string>& sent) {
  lcm::LCM lcm("memq://");
  std::vector<std::string> got;
  lcm.subscribeFunction(pattern, &record, &got);
  const char byte = 0;
  for (const auto& channel : sent) lcm.publish(channel, &byte, 1);
  while (lcm.handleTimeout(0) > 0) {
  }
  return got;
}

}  // namespace

TEST(ChannelRegex, EscapesEverySpecialCharacter) {
  EXPECT_EQ(ptz::escapeRegex("A.B"), "A\\.B");
  EXPECT_EQ(ptz::escapeRegex("\\^$.|?*+()[]{}"), "\\\\\\^\\$\\.\\|\\?\\*\\+\\(\\)\\[\\]\\{\\}");
  EXPECT_EQ(ptz::escapeRegex("PLAIN_1"), "PLAIN_1");
  EXPECT_EQ(ptz::channelsStartingWith("SIM."), "SIM\\..*");
}

TEST(ChannelRegex, APrefixOfSpecialsMatchesOnlyItself) {
  const std::string prefix = "R.*[(\\+?|^$";
  const std::vector<std::string> sent = {
      prefix + "STEREO_FRAME",      // the prefix itself: received
      prefix,                       // the prefix alone: received
      "RX*[(\\+?|^$STEREO_FRAME",   // '.' as any character
      "RRRR[(\\+?|^$STEREO_FRAME",  // '*' as a repetition
      "STEREO_FRAME",               // no prefix
      "R.*[(\\+?|^",                // shorter than the prefix
  };
  EXPECT_EQ(received(ptz::channelsStartingWith(prefix), sent),
            (std::vector<std::string>{prefix + "STEREO_FRAME", prefix}));
}

TEST(ChannelRegex, EachSpecialCharacterMatchesOnlyItself) {
  for (char c : std::string("\\^$.|?*+()[]{}")) {
    const std::string prefix = std::string("A") + c + "B_";
    const std::vector<std::string> sent = {prefix + "X", "AB_X", "AXB_X",
                                           "A" + std::string(2, c) + "B_X"};
    EXPECT_EQ(received(ptz::channelsStartingWith(prefix), sent),
              std::vector<std::string>{prefix + "X"})
        << "special character " << c;
  }
}
