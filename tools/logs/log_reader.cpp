#include "tools/logs/log_reader.hpp"

#include <sys/stat.h>

#include <cstdio>
#include <stdexcept>

namespace ptz::tools {

namespace {
constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;  // sync, eventnum, timestamp, lengths
constexpr uint32_t kSyncWord = 0xEDA1DA01;
}  // namespace

LogReader::LogReader(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw std::runtime_error("cannot open log '" + path + "'");
  file_bytes_ = st.st_size;
  log_ = std::make_unique<lcm::LogFile>(path, "r");
  if (!log_->good()) throw std::runtime_error("cannot read log '" + path + "'");
}

// Where the next sync word is at or after `from`, or -1.
int64_t LogReader::findSync(int64_t from) {
  FILE* fp = log_->getFilePtr();
  if (std::fseek(fp, from, SEEK_SET) != 0) return -1;
  uint32_t window = 0;
  int64_t pos = from;
  for (int c; (c = std::fgetc(fp)) != EOF; ++pos) {
    window = (window << 8) | static_cast<uint32_t>(c);
    if (pos - from >= 3 && window == kSyncWord) return pos - 3;
  }
  return -1;
}

const lcm::LogEvent* LogReader::next() {
  if (done_) return nullptr;
  const lcm::LogEvent* ev = log_->readNextEvent();
  // LCM's reader gives up at a damaged event: look for the next intact one ourselves.
  int64_t resume_from = end_of_last_ + 1;
  while (!ev) {
    const int64_t sync = resume_from < file_bytes_ ? findSync(resume_from) : -1;
    if (sync < 0) {
      done_ = true;
      if (end_of_last_ < file_bytes_) {
        breaks_.push_back({end_of_last_, file_bytes_ - end_of_last_,
                           "the log ends in a partial or unreadable event"});
      }
      return nullptr;
    }
    std::fseek(log_->getFilePtr(), sync, SEEK_SET);
    ev = log_->readNextEvent();
    resume_from = sync + 1;
  }
  const int64_t end = std::ftell(log_->getFilePtr());
  const int64_t start = end - kHeaderBytes - static_cast<int64_t>(ev->channel.size()) - ev->datalen;
  if (start > end_of_last_) {
    breaks_.push_back(
        {end_of_last_, start - end_of_last_, "unreadable bytes skipped up to the next event"});
  }
  end_of_last_ = end;
  ++events_;
  return ev;
}

std::string LogReader::describeBreaks() const {
  std::string text;
  for (const Break& b : breaks_) {
    text += path_ + ": " + b.what + " at byte " + std::to_string(b.offset) + " (" +
            std::to_string(b.bytes) + " bytes of " + std::to_string(file_bytes_) + ")\n";
  }
  return text;
}

}  // namespace ptz::tools
