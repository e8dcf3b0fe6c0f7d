#include "tools/logs/log_reader.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace ptz::tools {
namespace {

constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;  // sync, eventnum, timestamp, lengths
constexpr uint32_t kSyncWord = 0xEDA1DA01;
constexpr int32_t kMaxChannelBytes = 1000;  // as LCM's own reader

uint64_t bigEndian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

bool readAt(std::FILE* f, int64_t offset, void* out, size_t bytes) {
  return ::fseeko(f, offset, SEEK_SET) == 0 && std::fread(out, 1, bytes, f) == bytes;
}

std::string inQuotes(const std::string& path) {
  return "'" + path + "'";
}

// The mode a new file or folder gets (the process's umask applied), for what mkstemp made 0600.
mode_t createMode(mode_t full) {
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return full & ~mask;
}

std::string withoutTrailingSlash(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  return path;
}

}  // namespace

std::string logExitCodesHelp(const std::string& own_verdict, const std::string& unanswered) {
  std::string s = "Exit codes: 0 done (a damaged log is read as far as it goes, with a warning)";
  if (!own_verdict.empty()) s += "; 1 " + own_verdict;
  s += "; 2 bad flags or config file";
  if (!unanswered.empty()) s += "; 3 " + unanswered;
  return s +
         "; 4 the log does not exist, is not a file or cannot be read; 5 the log holds no "
         "complete event; 6 the file is not an LCM log; 7 the log lacks the channels needed; 8 "
         "an output could not be written; 9 could not run (no LCM, or an unexpected error).";
}

LogReader::LogReader(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw LogError(log_exit::kMissing, "log " + inQuotes(path) + ": " + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw LogError(log_exit::kMissing, "log " + inQuotes(path) + ": not a file" +
                                           (S_ISDIR(st.st_mode) ? " (a folder)" : ""));
  }
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) {
    throw LogError(log_exit::kMissing, "log " + inQuotes(path) + ": " + std::strerror(errno));
  }
  file_bytes_ = st.st_size;
  uint8_t sync[4];
  starts_with_sync_ = readAt(file_, 0, sync, 4) && bigEndian(sync, 4) == kSyncWord;
}

LogReader::~LogReader() {
  if (file_) std::fclose(file_);
}

bool LogReader::eventAt(int64_t offset) {
  if (offset + kHeaderBytes > file_bytes_) return false;
  uint8_t h[kHeaderBytes];
  if (!readAt(file_, offset, h, sizeof h) || bigEndian(h, 4) != kSyncWord) return false;
  const auto channel_bytes = static_cast<int32_t>(bigEndian(h + 20, 4));
  const auto data_bytes = static_cast<int32_t>(bigEndian(h + 24, 4));
  if (channel_bytes <= 0 || channel_bytes >= kMaxChannelBytes || data_bytes < 0) return false;
  const int64_t end = offset + kHeaderBytes + channel_bytes + data_bytes;
  if (end > file_bytes_) return false;  // cut off, or a length that is not one
  // The next event must start right after this one (or the file end, or a cut header there).
  uint8_t next[4];
  if (end + 4 <= file_bytes_ && (!readAt(file_, end, next, 4) || bigEndian(next, 4) != kSyncWord)) {
    return false;
  }
  std::string channel(static_cast<size_t>(channel_bytes), '\0');
  data_.resize(static_cast<size_t>(data_bytes));
  if (!readAt(file_, offset + kHeaderBytes, channel.data(), channel.size()) ||
      (data_bytes > 0 && std::fread(data_.data(), 1, data_.size(), file_) != data_.size())) {
    return false;
  }
  event_.eventnum = static_cast<int64_t>(bigEndian(h + 4, 8));
  event_.timestamp = static_cast<int64_t>(bigEndian(h + 12, 8));
  event_.channel = std::move(channel);
  event_.datalen = data_bytes;
  event_.data = data_.data();
  position_ = end;
  ++events_;
  ++channel_events_[event_.channel];
  return true;
}

int64_t LogReader::findSync(int64_t from) {
  std::array<uint8_t, 1 << 16> chunk{};
  for (int64_t at = from; at + 4 <= file_bytes_;) {
    const size_t n = static_cast<size_t>(std::min<int64_t>(chunk.size(), file_bytes_ - at));
    if (!readAt(file_, at, chunk.data(), n)) return -1;
    for (size_t i = 0; i + 4 <= n; ++i) {
      if (bigEndian(chunk.data() + i, 4) == kSyncWord) return at + static_cast<int64_t>(i);
    }
    at += static_cast<int64_t>(n) - 3;  // a sync word across the chunk boundary
  }
  return -1;
}

void LogReader::addBreak(int64_t from, int64_t to) {
  std::string what = to == file_bytes_ ? "the log ends in a partial or unreadable event (cut off)"
                     : from == 0
                         ? "the log does not start with an LCM event; bytes skipped up to the first"
                         : "unreadable bytes skipped up to the next event";
  breaks_.push_back({from, to - from, what});
}

const lcm::LogEvent* LogReader::next() {
  if (done_) return nullptr;
  if (position_ < file_bytes_ && eventAt(position_)) return &event_;
  // Damaged (or the end): the next intact event after the one that should start here.
  const int64_t damaged = position_;
  for (int64_t from = damaged + 1; damaged < file_bytes_;) {
    const int64_t sync = findSync(from);
    if (sync < 0) break;
    if (eventAt(sync)) {
      addBreak(damaged, sync);
      return &event_;
    }
    from = sync + 1;
  }
  done_ = true;
  if (damaged < file_bytes_) addBreak(damaged, file_bytes_);
  return nullptr;
}

void LogReader::requireEvents() const {
  if (events_ > 0) return;
  const std::string log = "log " + inQuotes(path_);
  if (file_bytes_ == 0) throw LogError(log_exit::kEmpty, log + " is empty (0 bytes)");
  const std::string size = std::to_string(file_bytes_) + " bytes";
  if (starts_with_sync_) {
    throw LogError(log_exit::kEmpty,
                   log + " holds no complete event: it is cut inside its first (" + size + ")");
  }
  throw LogError(log_exit::kNotLcm, log + " is not an LCM log: no event in its " + size +
                                        " (an LCM log starts with the sync word 0xEDA1DA01)");
}

bool LogReader::truncated() const {
  return done_ && !breaks_.empty() && breaks_.back().offset + breaks_.back().bytes == file_bytes_;
}

std::string LogReader::describeBreaks() const {
  std::string text;
  for (const Break& b : breaks_) {
    text += path_ + ": " + b.what + " at byte " + std::to_string(b.offset) + " (" +
            std::to_string(b.bytes) + " bytes of " + std::to_string(file_bytes_) + ")\n";
  }
  return text;
}

void LogReader::requireChannels(const std::vector<std::string>& all_of,
                                const std::vector<std::string>& any_of) const {
  auto has = [&](const std::string& c) { return channel_events_.count(c) > 0; };
  std::string missing;
  for (const auto& c : all_of) {
    if (!has(c)) missing += (missing.empty() ? "no " : ", no ") + c;
  }
  bool any = any_of.empty();
  std::string options;
  for (const auto& c : any_of) {
    any = any || has(c);
    options += (options.empty() ? "" : ", ") + c;
  }
  if (!any) missing += (missing.empty() ? "none of " : ", none of ") + options;
  if (missing.empty()) return;
  std::string held;
  for (const auto& [c, n] : channel_events_) {
    held += (held.empty() ? "" : ", ") + c + " (" + std::to_string(n) + ")";
  }
  throw LogError(log_exit::kNoChannels, "log " + inQuotes(path_) + " lacks the channels needed: " +
                                            missing + "; it has " + held);
}

OutputFile::OutputFile(const std::string& path) : path_(path) {
  std::string pattern = path + ".partial-XXXXXX";
  const int fd = ::mkstemp(pattern.data());
  if (fd < 0) {
    throw LogError(log_exit::kOutput,
                   "cannot write " + inQuotes(path) + ": " + std::strerror(errno));
  }
  ::close(fd);
  temp_ = pattern;
}

OutputFile::~OutputFile() {
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void OutputFile::commit() {
  ::chmod(temp_.c_str(), createMode(0666));
  if (::rename(temp_.c_str(), path_.c_str()) != 0) {
    throw LogError(log_exit::kOutput,
                   "cannot write " + inQuotes(path_) + ": " + std::strerror(errno));
  }
  committed_ = true;
}

OutputDir::OutputDir(const std::string& path) : path_(withoutTrailingSlash(path)) {
  std::string pattern = path_ + ".partial-XXXXXX";
  if (!::mkdtemp(pattern.data())) {
    throw LogError(log_exit::kOutput,
                   "cannot write " + inQuotes(path) + ": " + std::strerror(errno));
  }
  temp_ = pattern;
}

OutputDir::~OutputDir() {
  if (!committed_) removeTemp();
}

void OutputDir::removeTemp() {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(temp_, ec)) {
    std::filesystem::remove(entry.path(), ec);
  }
  std::filesystem::remove(temp_, ec);
}

void OutputDir::commit() {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path_, ec)) {
    ::chmod(temp_.c_str(), createMode(0777));
    if (::rename(temp_.c_str(), path_.c_str()) == 0) {
      committed_ = true;
      return;
    }
  }
  if (!fs::is_directory(path_, ec)) {
    throw LogError(log_exit::kOutput, "cannot write " + inQuotes(path_) + ": not a folder");
  }
  for (const auto& entry : fs::directory_iterator(temp_, ec)) {
    const fs::path to = fs::path(path_) / entry.path().filename();
    ::chmod(entry.path().c_str(), createMode(0666));
    if (::rename(entry.path().c_str(), to.c_str()) != 0) {
      throw LogError(log_exit::kOutput,
                     "cannot write " + inQuotes(to.string()) + ": " + std::strerror(errno));
    }
  }
  fs::remove(temp_, ec);
  committed_ = true;
}

}  // namespace ptz::tools
