// The log reader of the tools (tools/logs/log_reader.hpp): a log written from the input, read
// event by event with LogReader, each event decoded with decodeEvent as the tools decode theirs.
// Properties: the reader ends; every byte of the file is in an event or in a break (the breaks
// lie inside the file, in order, and describeBreaks names the file); requireEvents refuses
// exactly the logs without an event, as empty or not LCM, naming the file; a message costs at
// most a small multiple of its size to decode, and decoding throws nothing.
#include <string>

#include "fuzz/fuzz_support.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/logs/log_reader.hpp"

namespace {

constexpr int64_t kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr size_t kDecodeCostFactor = 4;
constexpr size_t kSlackBytes = 4096;

template <class Msg>
void decode(const lcm::LogEvent& ev, int64_t* undecodable) {
  Msg msg;
  ptz::fuzz::AllocationCount count;
  ptz::tools::decodeEvent(ev, &msg, undecodable);
  FUZZ_CHECK(count.bytes() <= kDecodeCostFactor * static_cast<size_t>(ev.datalen) + kSlackBytes,
             std::string("decoding an event of ") + std::to_string(ev.datalen) + " bytes as " +
                 Msg::getTypeName() + " allocated " + std::to_string(count.bytes()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::InputFile file(data, size, "run.lcmlog");
  ptz::tools::LogReader reader(file.path());
  FUZZ_CHECK(reader.fileBytes() == static_cast<int64_t>(size), "file size");
  int64_t events = 0, event_bytes = 0, undecodable = 0;
  while (const lcm::LogEvent* ev = reader.next()) {
    FUZZ_CHECK(++events <= static_cast<int64_t>(size) / kEventHeaderBytes, "more events than fit");
    FUZZ_CHECK(ev->datalen >= 0, "negative datalen");
    event_bytes += kEventHeaderBytes + static_cast<int64_t>(ev->channel.size()) + ev->datalen;
    decode<ptzstereo::stereo_frame_t>(*ev, &undecodable);
    decode<ptzstereo::object_pose_t>(*ev, &undecodable);
    decode<ptzstereo::ptz_state_t>(*ev, &undecodable);
    decode<ptzstereo::process_status_t>(*ev, &undecodable);
  }
  FUZZ_CHECK(reader.next() == nullptr, "events after the end");
  FUZZ_CHECK(reader.events() == events,
             "events() " + std::to_string(reader.events()) + ", read " + std::to_string(events));
  int64_t break_bytes = 0, end_of_previous = 0;
  for (const auto& b : reader.breaks()) {
    FUZZ_CHECK(b.offset >= end_of_previous && b.bytes > 0 &&
                   b.offset + b.bytes <= static_cast<int64_t>(size),
               "break at " + std::to_string(b.offset) + " of " + std::to_string(b.bytes) +
                   " bytes in a file of " + std::to_string(size));
    end_of_previous = b.offset + b.bytes;
    break_bytes += b.bytes;
  }
  FUZZ_CHECK(event_bytes + break_bytes == static_cast<int64_t>(size),
             std::to_string(event_bytes) + " bytes in events and " + std::to_string(break_bytes) +
                 " in breaks, the file has " + std::to_string(size));
  const std::string text = reader.describeBreaks();
  FUZZ_CHECK(text.empty() == reader.breaks().empty() &&
                 (text.empty() || ptz::fuzz::names(text, file.path())),
             "describeBreaks: " + text);
  try {
    reader.requireEvents();
    FUZZ_CHECK(events > 0, "a log without events passed requireEvents");
  } catch (const ptz::tools::LogError& e) {
    namespace code = ptz::tools::log_exit;
    FUZZ_CHECK(events == 0 && (e.exitCode() == code::kEmpty || e.exitCode() == code::kNotLcm) &&
                   ptz::fuzz::names(e.what(), file.path()),
               "requireEvents after " + std::to_string(events) + " events: exit code " +
                   std::to_string(e.exitCode()) + ", " + e.what());
  }
  return 0;
}
