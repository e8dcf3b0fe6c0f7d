#include "tools/mcap/mcap_writer.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace ptz::mcap {

namespace {

constexpr char kMagic[] = "\x89MCAP0\r\n";
constexpr size_t kMagicSize = 8;
constexpr size_t kRecordPrefix = 1 + 8;  // opcode, u64 content length

enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

constexpr uint64_t kU32Max = std::numeric_limits<uint32_t>::max();

void putU8(std::string& out, uint8_t v) {
  out.push_back(static_cast<char>(v));
}
// Little-endian whatever the host.
template <typename T>
void putLe(std::string& out, T v) {
  for (size_t i = 0; i < sizeof(T); ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void putU16(std::string& out, uint16_t v) {
  putLe(out, v);
}
void putU32(std::string& out, uint32_t v) {
  putLe(out, v);
}
void putU64(std::string& out, uint64_t v) {
  putLe(out, v);
}

// Every u32 length prefix is checked where the caller's input enters (checkLength), so here it
// fits.
void putString(std::string& out, const std::string& s) {
  putU32(out, static_cast<uint32_t>(s.size()));
  out += s;
}

void checkLength(const std::string& field, uint64_t size_bytes) {
  if (size_bytes > kU32Max) {
    throw std::invalid_argument("mcap: " + field + " is " + std::to_string(size_bytes) +
                                " bytes, more than its u32 length prefix allows");
  }
}

uint64_t stringMapBytes(const std::map<std::string, std::string>& m) {
  uint64_t n = 0;
  for (const auto& [k, v] : m) n += 4 + k.size() + 4 + v.size();
  return n;
}

void putStringMap(std::string& out, const std::map<std::string, std::string>& m) {
  putU32(out, static_cast<uint32_t>(stringMapBytes(m)));
  for (const auto& [k, v] : m) {
    putString(out, k);
    putString(out, v);
  }
}

void putRecord(std::string& out, uint8_t op, const std::string& content) {
  putU8(out, op);
  putU64(out, content.size());
  out += content;
}

// zlib's crc32 takes a 32-bit length: feed big buffers in pieces.
uint32_t crc32Update(uint32_t crc, const char* data, size_t size) {
  uLong c = crc;
  while (size > 0) {
    const size_t n = std::min<size_t>(size, 1u << 30);
    c = ::crc32(c, reinterpret_cast<const Bytef*>(data), static_cast<uInt>(n));
    data += n;
    size -= n;
  }
  return static_cast<uint32_t>(c);
}

}  // namespace

struct Writer::Zstd {
  ZSTD_CCtx* ctx = ZSTD_createCCtx();
  ~Zstd() { ZSTD_freeCCtx(ctx); }
};

Writer::Writer(const std::string& path, WriterOptions options)
    : path_(path), options_(std::move(options)) {
  if (options_.compression == "zstd") {
    if (options_.zstd_level < ZSTD_minCLevel() || options_.zstd_level > ZSTD_maxCLevel()) {
      throw std::invalid_argument("mcap: zstd_level " + std::to_string(options_.zstd_level) +
                                  " outside " + std::to_string(ZSTD_minCLevel()) + ".." +
                                  std::to_string(ZSTD_maxCLevel()));
    }
    zstd_ = std::make_unique<Zstd>();
    if (!zstd_->ctx) throw std::runtime_error("mcap: cannot create a zstd context");
  } else if (!options_.compression.empty()) {
    throw std::invalid_argument("mcap: compression \"" + options_.compression +
                                "\" not supported (\"zstd\" or \"\")");
  }
  checkLength("Header.profile", options_.profile.size());
  checkLength("Header.library", options_.library.size());
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw std::runtime_error("mcap: cannot create " + path_ + ": " + std::strerror(errno));
  }
  std::string header;
  putString(header, options_.profile);
  putString(header, options_.library);
  std::string out(kMagic, kMagicSize);
  putRecord(out, kHeader, header);
  emit(out);
}

Writer::~Writer() {
  if (closed_) return;
  try {
    close();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
  }
  if (fd_ >= 0) ::close(fd_);
}

void Writer::checkOpen() const {
  if (closed_) throw std::runtime_error("mcap " + path_ + ": writer already closed");
}

void Writer::fail(const std::string& what) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  closed_ = true;
  throw std::runtime_error("mcap " + path_ + ": " + what);
}

void Writer::writeOut(const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd_, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      fail(std::string("write failed at byte ") + std::to_string(file_offset_) + ": " +
           (n < 0 ? std::strerror(errno) : "wrote nothing"));
    }
    data += n;
    size -= static_cast<size_t>(n);
    file_offset_ += static_cast<uint64_t>(n);
  }
}

void Writer::emit(const std::string& bytes) {
  if (in_data_section_) data_crc_ = crc32Update(data_crc_, bytes.data(), bytes.size());
  writeOut(bytes.data(), bytes.size());
}

uint16_t Writer::addSchema(const std::string& name, const std::string& encoding,
                           const std::string& data) {
  checkOpen();
  if (schemas_.size() >= std::numeric_limits<uint16_t>::max()) {
    throw std::invalid_argument("mcap " + path_ + ": no schema id left (65535 schemas)");
  }
  checkLength("Schema.name", name.size());
  checkLength("Schema.encoding", encoding.size());
  checkLength("Schema.data of " + name, data.size());
  const auto id = static_cast<uint16_t>(schemas_.size() + 1);
  schemas_.push_back(Schema{id, name, encoding, data});
  return id;
}

uint16_t Writer::addChannel(uint16_t schema_id, const std::string& topic,
                            const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata) {
  checkOpen();
  if (channels_.size() >= std::numeric_limits<uint16_t>::max()) {
    throw std::invalid_argument("mcap " + path_ + ": no channel id left (65535 channels)");
  }
  if (schema_id > schemas_.size()) {
    throw std::invalid_argument("mcap " + path_ + ": channel " + topic + " names schema id " +
                                std::to_string(schema_id) + ", which was never added");
  }
  checkLength("Channel.topic", topic.size());
  checkLength("Channel.message_encoding of " + topic, message_encoding.size());
  for (const auto& [k, v] : metadata) {
    checkLength("Channel.metadata key of " + topic, k.size());
    checkLength("Channel.metadata value of " + topic, v.size());
  }
  checkLength("Channel.metadata of " + topic, stringMapBytes(metadata));
  const auto id = static_cast<uint16_t>(channels_.size() + 1);
  channels_.push_back(Channel{id, schema_id, topic, message_encoding, metadata});
  return id;
}

void Writer::writeSchemaRecord(std::string& out, const Schema& s) const {
  std::string c;
  putU16(c, s.id);
  putString(c, s.name);
  putString(c, s.encoding);
  putString(c, s.data);  // uint32 length-prefixed bytes: the same layout as a String
  putRecord(out, kSchema, c);
}

void Writer::writeChannelRecord(std::string& out, const Channel& ch) const {
  std::string c;
  putU16(c, ch.id);
  putU16(c, ch.schema_id);
  putString(c, ch.topic);
  putString(c, ch.message_encoding);
  putStringMap(c, ch.metadata);
  putRecord(out, kChannel, c);
}

void Writer::write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns,
                   const void* data, size_t size) {
  checkOpen();
  if (channel_id == 0 || channel_id > channels_.size()) {
    throw std::invalid_argument("mcap " + path_ + ": message on channel id " +
                                std::to_string(channel_id) + ", which was never added");
  }
  if (size > 0 && data == nullptr) {
    throw std::invalid_argument("mcap " + path_ + ": message of " + std::to_string(size) +
                                " bytes without data");
  }
  Channel& ch = channels_[channel_id - 1];
  const uint64_t content_bytes = 2 + 4 + 8 + 8 + static_cast<uint64_t>(size);
  const uint64_t record_bytes = kRecordPrefix + content_bytes;
  // A Message Index's array has a u32 byte length: 16 bytes per entry.
  const auto it = chunk_index_.find(channel_id);
  const bool index_full = it != chunk_index_.end() && it->second.size() >= kU32Max / 16;
  if (!chunk_.empty() && (chunk_.size() + record_bytes > options_.chunk_size_bytes || index_full)) {
    flushChunk();
  }
  if (ch.schema_id != 0 && !schemas_[ch.schema_id - 1].written) {
    writeSchemaRecord(chunk_, schemas_[ch.schema_id - 1]);
    schemas_[ch.schema_id - 1].written = true;
  }
  if (!ch.written) {
    writeChannelRecord(chunk_, ch);
    ch.written = true;
  }
  chunk_index_[channel_id].push_back(IndexEntry{log_time_ns, chunk_.size()});
  putU8(chunk_, kMessage);
  putU64(chunk_, content_bytes);
  putU16(chunk_, channel_id);
  putU32(chunk_, static_cast<uint32_t>(ch.message_count));  // wraps after 2^32 messages
  putU64(chunk_, log_time_ns);
  putU64(chunk_, publish_time_ns);
  if (size > 0) chunk_.append(static_cast<const char*>(data), size);

  if (!chunk_has_messages_) {
    chunk_start_ns_ = chunk_end_ns_ = log_time_ns;
    chunk_has_messages_ = true;
  }
  chunk_start_ns_ = std::min(chunk_start_ns_, log_time_ns);
  chunk_end_ns_ = std::max(chunk_end_ns_, log_time_ns);
  if (message_count_ == 0) start_ns_ = end_ns_ = log_time_ns;
  start_ns_ = std::min(start_ns_, log_time_ns);
  end_ns_ = std::max(end_ns_, log_time_ns);
  ++message_count_;
  ++ch.message_count;
  if (chunk_.size() >= options_.chunk_size_bytes) flushChunk();
}

void Writer::flushChunk() {
  if (chunk_.empty()) return;
  const uint32_t crc = crc32Update(0, chunk_.data(), chunk_.size());
  const std::string* records = &chunk_;
  if (zstd_) {
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const size_t n = ZSTD_compressCCtx(zstd_->ctx, compressed_.data(), compressed_.size(),
                                       chunk_.data(), chunk_.size(), options_.zstd_level);
    if (ZSTD_isError(n)) fail(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    compressed_.resize(n);
    records = &compressed_;
  }
  ChunkIndex index{};
  index.start_ns = chunk_has_messages_ ? chunk_start_ns_ : 0;
  index.end_ns = chunk_has_messages_ ? chunk_end_ns_ : 0;
  index.offset = file_offset_;
  index.compressed_size = records->size();
  index.uncompressed_size = chunk_.size();

  std::string fields;
  putU64(fields, index.start_ns);
  putU64(fields, index.end_ns);
  putU64(fields, index.uncompressed_size);
  putU32(fields, crc);
  putString(fields, options_.compression);
  putU64(fields, index.compressed_size);
  std::string prefix;
  putU8(prefix, kChunk);
  putU64(prefix, fields.size() + records->size());
  prefix += fields;
  index.length = prefix.size() + records->size();
  emit(prefix);
  emit(*records);

  // One Message Index per channel of the chunk, entries by log time (a stable sort keeps the
  // order of equal times).
  std::string indexes;
  for (auto& [channel_id, entries] : chunk_index_) {
    std::stable_sort(entries.begin(), entries.end(), [](const IndexEntry& a, const IndexEntry& b) {
      return a.log_time_ns < b.log_time_ns;
    });
    index.message_index_offsets[channel_id] = file_offset_ + indexes.size();
    std::string c;
    putU16(c, channel_id);
    putU32(c, static_cast<uint32_t>(entries.size() * 16));
    for (const auto& e : entries) {
      putU64(c, e.log_time_ns);
      putU64(c, e.offset);
    }
    putRecord(indexes, kMessageIndex, c);
  }
  index.message_index_length = indexes.size();
  emit(indexes);
  chunk_indexes_.push_back(std::move(index));
  chunk_.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
  // A huge chunk's buffers are not kept for the next ones.
  if (chunk_.capacity() > 2 * options_.chunk_size_bytes + (1u << 20)) std::string().swap(chunk_);
  if (compressed_.capacity() > 2 * options_.chunk_size_bytes + (1u << 20)) {
    std::string().swap(compressed_);
  }
}

void Writer::addMetadata(const std::string& name,
                         const std::map<std::string, std::string>& values) {
  checkOpen();
  checkLength("Metadata.name", name.size());
  for (const auto& [k, v] : values) {
    checkLength("Metadata key of " + name, k.size());
    checkLength("Metadata value of " + name, v.size());
  }
  checkLength("Metadata map of " + name, stringMapBytes(values));
  std::string c;
  putString(c, name);
  putStringMap(c, values);
  std::string record;
  putRecord(record, kMetadata, c);
  metadata_indexes_.push_back(MetadataIndex{file_offset_, record.size(), name});
  emit(record);
}

uint64_t Writer::messageCount(uint16_t channel_id) const {
  if (channel_id == 0 || channel_id > channels_.size()) return 0;
  return channels_[channel_id - 1].message_count;
}

std::string Writer::statisticsRecord() const {
  std::string c;
  putU64(c, message_count_);
  putU16(c, static_cast<uint16_t>(schemas_.size()));
  putU32(c, static_cast<uint32_t>(channels_.size()));
  putU32(c, 0);  // attachments
  putU32(c, static_cast<uint32_t>(metadata_indexes_.size()));
  putU32(c, static_cast<uint32_t>(chunk_indexes_.size()));
  putU64(c, message_count_ ? start_ns_ : 0);
  putU64(c, message_count_ ? end_ns_ : 0);
  std::string counts;
  for (const auto& ch : channels_) {
    if (ch.message_count == 0) continue;
    putU16(counts, ch.id);
    putU64(counts, ch.message_count);
  }
  putU32(c, static_cast<uint32_t>(counts.size()));
  c += counts;
  std::string record;
  putRecord(record, kStatistics, c);
  return record;
}

void Writer::close() {
  if (closed_) return;
  flushChunk();
  // Schemas and channels no message used: in the data section too, since the summary's copies
  // must duplicate records of the data section.
  std::string unused;
  for (auto& s : schemas_) {
    if (!s.written) writeSchemaRecord(unused, s);
    s.written = true;
  }
  for (auto& ch : channels_) {
    if (!ch.written) writeChannelRecord(unused, ch);
    ch.written = true;
  }
  emit(unused);

  // Data End's CRC covers every byte before it, from the leading magic on.
  std::string data_end;
  putU32(data_end, data_crc_);
  std::string record;
  putRecord(record, kDataEnd, data_end);
  emit(record);
  in_data_section_ = false;

  const uint64_t summary_start = file_offset_;
  std::string summary;
  struct Group {
    uint8_t op;
    uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](uint8_t op, auto&& write_records) {
    const size_t begin = summary.size();
    write_records();
    if (summary.size() > begin)
      groups.push_back({op, summary_start + begin, summary.size() - begin});
  };
  group(kSchema, [&] {
    for (const auto& s : schemas_) writeSchemaRecord(summary, s);
  });
  group(kChannel, [&] {
    for (const auto& ch : channels_) writeChannelRecord(summary, ch);
  });
  group(kStatistics, [&] { summary += statisticsRecord(); });
  group(kChunkIndex, [&] {
    for (const auto& ci : chunk_indexes_) {
      std::string c;
      putU64(c, ci.start_ns);
      putU64(c, ci.end_ns);
      putU64(c, ci.offset);
      putU64(c, ci.length);
      putU32(c, static_cast<uint32_t>(ci.message_index_offsets.size() * (2 + 8)));
      for (const auto& [channel_id, offset] : ci.message_index_offsets) {
        putU16(c, channel_id);
        putU64(c, offset);
      }
      putU64(c, ci.message_index_length);
      putString(c, options_.compression);
      putU64(c, ci.compressed_size);
      putU64(c, ci.uncompressed_size);
      putRecord(summary, kChunkIndex, c);
    }
  });
  group(kMetadataIndex, [&] {
    for (const auto& mi : metadata_indexes_) {
      std::string c;
      putU64(c, mi.offset);
      putU64(c, mi.length);
      putString(c, mi.name);
      putRecord(summary, kMetadataIndex, c);
    }
  });
  const uint64_t summary_offset_start = summary_start + summary.size();
  for (const auto& g : groups) {
    std::string c;
    putU8(c, g.op);
    putU64(c, g.start);
    putU64(c, g.length);
    putRecord(summary, kSummaryOffset, c);
  }
  // The summary CRC covers the summary and summary offset sections and the footer up to its CRC.
  putU8(summary, kFooter);
  putU64(summary, 8 + 8 + 4);
  putU64(summary, summary_start);
  putU64(summary, summary_offset_start);
  putU32(summary, crc32Update(0, summary.data(), summary.size()));
  summary.append(kMagic, kMagicSize);
  emit(summary);

  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    closed_ = true;
    throw std::runtime_error("mcap " + path_ + ": closing failed: " + std::strerror(errno));
  }
  closed_ = true;
}

}  // namespace ptz::mcap
