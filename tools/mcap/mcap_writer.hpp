// Writes MCAP files (https://mcap.dev/spec, major version 0): messages in chunks (zstd or
// uncompressed) with a Message Index per channel after each chunk, then a summary (Schemas,
// Channels, Statistics, Chunk Indexes, Metadata Indexes, one Summary Offset per group) and the
// Footer, both CRC-checked (data section CRC in Data End, summary CRC in the Footer). A Schema and
// a Channel are written into the chunk of their first message, so a reader that streams the file
// meets them before it needs them. No LCM here: the exporters feed it bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace ptz::mcap {

struct WriterOptions {
  std::string compression = "zstd";  // "zstd" or "" (none)
  int zstd_level = 3;
  // A chunk is written once its records reach this size; a message bigger than it gets a chunk of
  // its own (the chunk then exceeds it).
  size_t chunk_size_bytes = 4u << 20;
  std::string profile = "";  // Header.profile ("" or e.g. "ros1"; custom ones start with "x-")
  std::string library = "ptzstereo";
};

// Every failure throws std::runtime_error (file errors: the path and what failed, e.g. "No space
// left on device") or std::invalid_argument (a bad id, a field too long for its u32 length). After
// a file error the writer is closed: further calls throw.
class Writer {
 public:
  // Creates (truncates) the file and writes the magic and Header.
  Writer(const std::string& path, WriterOptions options = {});
  // Closes if not closed; an error then is printed on stderr (a destructor does not throw).
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Ids count from 1; at most 65535 schemas and 65535 channels. schema_id 0: no schema.
  uint16_t addSchema(const std::string& name, const std::string& encoding, const std::string& data);
  uint16_t addChannel(uint16_t schema_id, const std::string& topic,
                      const std::string& message_encoding,
                      const std::map<std::string, std::string>& metadata = {});
  // Log times may come slightly out of order: chunk and file time ranges are min/max, and each
  // chunk's message index is sorted by log time. The sequence is the channel's own count, from 0.
  void write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns, const void* data,
             size_t size);
  // A Metadata record (outside chunks) and its index in the summary.
  void addMetadata(const std::string& name, const std::map<std::string, std::string>& values);
  // Writes the last chunk, the summary, the footer and the closing magic, and closes the file.
  void close();

  bool closed() const { return closed_; }
  const std::string& path() const { return path_; }
  uint64_t messageCount() const { return message_count_; }
  uint64_t messageCount(uint16_t channel_id) const;  // 0 for an unknown channel
  uint32_t chunkCount() const { return static_cast<uint32_t>(chunk_indexes_.size()); }
  uint64_t bytesWritten() const { return file_offset_; }  // the file's size once closed

 private:
  struct Schema {
    uint16_t id;
    std::string name, encoding, data;
    bool written = false;
  };
  struct Channel {
    uint16_t id, schema_id;
    std::string topic, message_encoding;
    std::map<std::string, std::string> metadata;
    bool written = false;
    uint64_t message_count = 0;
  };
  struct IndexEntry {
    uint64_t log_time_ns, offset;
  };
  struct ChunkIndex {
    uint64_t start_ns, end_ns, offset, length;
    std::map<uint16_t, uint64_t> message_index_offsets;
    uint64_t message_index_length, compressed_size, uncompressed_size;
  };
  struct MetadataIndex {
    uint64_t offset, length;
    std::string name;
  };

  void checkOpen() const;
  void writeSchemaRecord(std::string& out, const Schema& s) const;
  void writeChannelRecord(std::string& out, const Channel& c) const;
  void flushChunk();
  void emit(const std::string& bytes);  // to the file, counted in the data section CRC if open
  void writeOut(const char* data, size_t size);
  void fail(const std::string& what);  // closes the file and throws
  std::string statisticsRecord() const;

  std::string path_;
  WriterOptions options_;
  int fd_ = -1;
  bool closed_ = false;
  uint64_t file_offset_ = 0;
  uint32_t data_crc_ = 0;
  bool in_data_section_ = true;

  std::vector<Schema> schemas_;    // id = index + 1
  std::vector<Channel> channels_;  // id = index + 1

  // The open chunk: its records uncompressed, its messages' index by channel, its time range.
  std::string chunk_;
  std::map<uint16_t, std::vector<IndexEntry>> chunk_index_;
  uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  bool chunk_has_messages_ = false;

  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<MetadataIndex> metadata_indexes_;
  uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;

  struct Zstd;
  std::unique_ptr<Zstd> zstd_;
  std::string compressed_;  // reused between chunks
};

}  // namespace ptz::mcap
