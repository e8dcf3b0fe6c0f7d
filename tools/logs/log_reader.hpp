// Reads an LCM log event by event (lcm::LogFile) and notes where it is broken. LCM's reader
// stops at a damaged event; this one then resumes at the next sync word, so the rest of the log
// is still read. Gaps are found from the file offsets (an event is 28 bytes of header + channel
// + data).
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ptz::tools {

class LogReader {
 public:
  // Throws std::runtime_error naming the file when it cannot be opened.
  explicit LogReader(const std::string& path);

  // The next event, or nullptr at the end (then breaks() is complete).
  const lcm::LogEvent* next();

  struct Break {
    int64_t offset = 0;  // byte offset in the file where the unreadable part starts
    int64_t bytes = 0;
    std::string what;
  };
  const std::vector<Break>& breaks() const { return breaks_; }
  int64_t events() const { return events_; }
  int64_t fileBytes() const { return file_bytes_; }
  // One line per break, for messages and reports ("" when the log is whole).
  std::string describeBreaks() const;

 private:
  int64_t findSync(int64_t from);

  std::string path_;
  std::unique_ptr<lcm::LogFile> log_;
  int64_t file_bytes_ = 0;
  int64_t end_of_last_ = 0;
  int64_t events_ = 0;
  bool done_ = false;
  std::vector<Break> breaks_;
};

// Decodes one logged message; counts it in *undecodable when it does not decode.
template <typename T>
bool decodeEvent(const lcm::LogEvent& ev, T* msg, int64_t* undecodable) {
  if (msg->decode(ev.data, 0, ev.datalen) >= 0) return true;
  ++*undecodable;
  return false;
}

}  // namespace ptz::tools
