// Reads an LCM log event by event and notes where it is broken. Every event's header is checked
// against the file before anything is read or allocated (sync word, channel length, data length
// within the file, the next event's sync word right after it); at a damaged event the reader
// resumes at the next intact one, so the rest of the log is still read, and records at which
// byte and how much was lost. A missing, empty or foreign file is a LogError with its own exit
// code, the same in every program that reads logs.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/transport/message_check.hpp"

namespace ptz::tools {

// The exit codes of the programs that read logs (ptz-log-summary, ptz-replay, ptz-identify,
// ptz-report), one meaning each; each program's README and --help list those it uses.
namespace log_exit {
constexpr int kOk = 0;          // done (a damaged log is read as far as it goes, with a warning)
constexpr int kVerdict = 1;     // the program's own negative result (its README says which)
constexpr int kUsage = 2;       // bad flags or config file
constexpr int kUnanswered = 3;  // ptz-replay: frames ptz-detect did not answer
constexpr int kMissing = 4;     // the log does not exist, is not a file or cannot be read
constexpr int kEmpty = 5;       // the log holds no complete event (0 bytes, or cut in its first)
constexpr int kNotLcm = 6;      // the file is not an LCM log
constexpr int kNoChannels = 7;  // the log lacks the channels the program needs
constexpr int kOutput = 8;      // an output file or folder could not be written
constexpr int kFailed = 9;      // could not run: no LCM, or an unexpected error (message says)
}  // namespace log_exit

// The codes above for a program's --help: "exit codes: 0 ...; 1 OWN_VERDICT; 2 ...". Codes 1 and
// 3 only when the program has them (own_verdict, unanswered not empty).
std::string logExitCodesHelp(const std::string& own_verdict, const std::string& unanswered = "");

// A log a program cannot use; exitCode() is one of log_exit.
class LogError : public std::runtime_error {
 public:
  LogError(int exit_code, const std::string& what)
      : std::runtime_error(what), exit_code_(exit_code) {}
  int exitCode() const { return exit_code_; }

 private:
  int exit_code_;
};

class LogReader {
 public:
  // Throws LogError(kMissing) naming the file: no such file, not a regular file, unreadable.
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // The next intact event (valid until the next call), or nullptr at the end (then breaks() is
  // complete).
  const lcm::LogEvent* next();
  // After reading: throws LogError unless the log held an intact event: kEmpty for 0 bytes or
  // an LCM log cut inside its first event, kNotLcm for anything else.
  void requireEvents() const;

  struct Break {
    int64_t offset = 0;  // byte offset in the file where the unreadable part starts
    int64_t bytes = 0;
    std::string what;
  };
  const std::vector<Break>& breaks() const { return breaks_; }
  // The log ends inside an event (cut off: a logger killed, a copy interrupted).
  bool truncated() const;
  int64_t events() const { return events_; }
  int64_t fileBytes() const { return file_bytes_; }
  const std::string& path() const { return path_; }
  // Intact events per channel so far.
  const std::map<std::string, int64_t>& channelEvents() const { return channel_events_; }
  // One line per break, for messages and reports ("" when the log is whole).
  std::string describeBreaks() const;
  // After reading: throws LogError(kNoChannels) naming what is missing and what the log holds
  // unless it had events on every channel of `all_of` and on at least one of `any_of`.
  void requireChannels(const std::vector<std::string>& all_of,
                       const std::vector<std::string>& any_of = {}) const;

 private:
  bool eventAt(int64_t offset);  // reads the event at offset into event_ when it is intact
  int64_t findSync(int64_t from);
  void addBreak(int64_t from, int64_t to);

  std::string path_;
  std::FILE* file_ = nullptr;  // the log, read with fseeko/fread only
  int64_t file_bytes_ = 0;
  int64_t position_ = 0;  // where the next event should start
  int64_t events_ = 0;
  bool done_ = false;
  bool starts_with_sync_ = false;
  lcm::LogEvent event_{};
  std::vector<uint8_t> data_;
  std::vector<Break> breaks_;
  std::map<std::string, int64_t> channel_events_;
};

// Decodes one logged message, checked against its bytes first (message_check.hpp: lcm-gen's
// decode would size arrays from a damaged count and throw on a string of length 0; found by
// fuzz/fuzz_log_reader); counts it in *undecodable when it does not decode.
template <typename T>
bool decodeEvent(const lcm::LogEvent& ev, T* msg, int64_t* undecodable) {
  std::string why;
  if (ev.datalen >= 0 && decodeChecked(ev.data, static_cast<size_t>(ev.datalen), msg, &why)) {
    return true;
  }
  ++*undecodable;
  return false;
}

// A file written under a temporary name beside `path` and renamed to it by commit(); without
// commit() (an error, an exception) the temporary file is removed: no partial output is left.
class OutputFile {
 public:
  // Throws LogError(kOutput) naming the path when the folder cannot take a file.
  explicit OutputFile(const std::string& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  // Where to write meanwhile.
  const std::string& tempPath() const { return temp_; }
  // Throws LogError(kOutput) when the rename fails.
  void commit();

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

// A folder of files written in a temporary folder beside `path`; commit() moves them into `path`
// (created if needed; other files there are left alone). Without commit() they are removed.
class OutputDir {
 public:
  explicit OutputDir(const std::string& path);
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;
  const std::string& tempPath() const { return temp_; }
  void commit();

 private:
  void removeTemp();
  std::string path_, temp_;
  bool committed_ = false;
};

}  // namespace ptz::tools
