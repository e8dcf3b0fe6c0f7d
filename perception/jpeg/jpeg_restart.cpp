#include "perception/jpeg/jpeg_restart.hpp"

#include <algorithm>
#include <cstring>
#include <numeric>

#include "common/transport/message_check.hpp"

namespace ptz::perception {

namespace {

int be16(const uint8_t* p) {
  return p[0] << 8 | p[1];
}

// Markers that may come before the scan of a baseline JPEG, besides SOF0/1, DRI and SOS: tables,
// application data, comments. Anything else (another SOF, DNL, arithmetic tables) is not indexed.
bool plainSegment(uint8_t m) {
  return m == 0xC4 || m == 0xDB || m == 0xFE || (m >= 0xE0 && m <= 0xEF);
}

}  // namespace

JpegRestartIndex::JpegRestartIndex(const uint8_t* data, size_t size, bool use_restarts)
    : data_(data), size_(size) {
  if (!use_restarts || !index()) {
    seg_begin_.clear();
    seg_end_.clear();
  }
}

bool JpegRestartIndex::index() {
  const uint8_t* d = data_;
  const size_t n = size_;
  // Offsets are kept in 32 bits; a frame is far smaller.
  if (d == nullptr || n < 4 || n > UINT32_MAX || d[0] != 0xFF || d[1] != 0xD8) return false;
  // The markers up to and including SOS, each segment inside the bytes.
  size_t p = 2;
  bool sof = false;
  int hmax = 0, vmax = 0;
  while (true) {
    if (p >= n || d[p] != 0xFF) return false;
    while (p < n && d[p] == 0xFF) ++p;  // fill bytes before a marker
    if (p + 2 >= n) return false;
    const uint8_t m = d[p];
    const size_t len = static_cast<size_t>(be16(d + p + 1));
    if (len < 2 || len > n - (p + 1)) return false;
    const uint8_t* s = d + p + 3;  // the segment's payload, len - 2 bytes
    const size_t payload = len - 2;
    const size_t payload_at = p + 3;
    p = p + 1 + len;
    if (m == 0xC0 || m == 0xC1) {
      // 8-bit samples, 3 components, sampling factors 1..4.
      if (sof || payload != 6 + 3 * 3 || s[0] != 8 || s[5] != 3) return false;
      sof = true;
      height_offset_ = payload_at + 1;
      height_ = be16(s + 1);
      width_ = be16(s + 3);
      for (int c = 0; c < 3; ++c) {
        const int h = s[7 + 3 * c] >> 4, v = s[7 + 3 * c] & 15;
        if (h < 1 || h > 4 || v < 1 || v > 4) return false;
        hmax = std::max(hmax, h);
        vmax = std::max(vmax, v);
      }
    } else if (m == 0xDD) {
      if (payload != 2) return false;
      interval_ = be16(s);
    } else if (m == 0xDA) {
      // One scan of all three components (interleaved): its segments hold whole MCUs.
      if (!sof || payload != 1 + 2 * 3 + 3 || s[0] != 3) return false;
      header_end_ = p;
      break;
    } else if (!plainSegment(m)) {
      return false;
    }
  }
  // libjpeg refuses sides over JPEG_MAX_DIMENSION (65500); a band of fewer rows it would not.
  if (interval_ <= 0 || width_ <= 0 || height_ <= 0 || width_ > 65500 || height_ > 65500) {
    return false;
  }
  const int mcu_w = hmax * 8;
  mcu_h_ = vmax * 8;
  mcus_per_row_ = (width_ + mcu_w - 1) / mcu_w;
  const bool tiles = interval_ < mcus_per_row_ && mcus_per_row_ % interval_ == 0;
  tiles_per_row_ = tiles ? static_cast<int>(mcus_per_row_ / interval_) : 1;
  tile_w_ = tiles ? static_cast<int>(interval_) * mcu_w : width_;
  mcu_rows_ = (height_ + mcu_h_ - 1) / mcu_h_;
  const int64_t mcus = int64_t{mcus_per_row_} * mcu_rows_;
  const int64_t segments = (mcus + interval_ - 1) / interval_;
  // Each segment takes at least a byte and its marker two: a claim of more is a lie, refused
  // before anything is allocated for it.
  if (segments > static_cast<int64_t>((n - header_end_) / 2)) return false;
  seg_begin_.reserve(static_cast<size_t>(segments));
  seg_end_.reserve(static_cast<size_t>(segments));
  // The entropy-coded data: FF 00 is a stuffed FF, FF fill bytes may precede a marker; the only
  // markers allowed are RST0..7 in sequence between segments, and EOI after the last.
  size_t begin = header_end_, q = begin;
  while (true) {
    const void* f = q < n ? std::memchr(d + q, 0xFF, n - q) : nullptr;
    if (f == nullptr) return false;
    const size_t ff = static_cast<size_t>(static_cast<const uint8_t*>(f) - d);
    size_t r = ff;
    while (r < n && d[r] == 0xFF) ++r;
    if (r >= n) return false;
    const uint8_t c = d[r];
    q = r + 1;
    if (c == 0x00) continue;
    if (c != 0xD9 && (c < 0xD0 || c > 0xD7)) return false;
    if (ff == begin) return false;  // an empty segment
    if (static_cast<int64_t>(seg_begin_.size()) == segments) return false;
    seg_begin_.push_back(static_cast<uint32_t>(begin));
    seg_end_.push_back(static_cast<uint32_t>(ff));
    if (c == 0xD9) break;
    if (c != 0xD0 + ((seg_begin_.size() - 1) & 7)) return false;
    begin = q;
  }
  if (static_cast<int64_t>(seg_begin_.size()) != segments) return false;
  // readJpegHeader's count of scans (FF DA anywhere) within its limit, as the stream path needs:
  // the entropy-coded data holds none (every FF there is stuffing, fill or a marker seen above),
  // the header and what follows EOI may.
  int scans = 0;
  for (size_t i = 0; i + 1 < n; ++i) {
    if (i == header_end_) i = q;  // past EOI
    if (i + 1 < n && d[i] == 0xFF && d[i + 1] == 0xDA) ++scans;
  }
  return scans <= kMaxJpegScans;
}

int JpegRestartIndex::bandStart(int row) const {
  if (!usable() || row <= 0) return 0;
  // Row r begins a segment when r * mcus_per_row is a multiple of the interval.
  const int64_t step = interval_ / std::gcd(int64_t{mcus_per_row_}, interval_);
  return static_cast<int>(row - row % step);
}

bool JpegRestartIndex::tile(int r0, int r1, int c0, int c1, std::vector<uint8_t>* out) const {
  if (!usable() || r0 < 0 || r1 <= r0 || r1 > mcu_rows_ || c0 < 0 || c1 <= c0 ||
      c1 > tiles_per_row_) {
    return false;
  }
  if (tiles_per_row_ == 1) return band(r0, r1, out);
  const int h = std::min(r1 * mcu_h_, height_) - r0 * mcu_h_;
  const int w = std::min(c1 * tile_w_, width_) - c0 * tile_w_;
  const auto segment = [&](int r, int c) {
    return static_cast<size_t>(r) * static_cast<size_t>(tiles_per_row_) + static_cast<size_t>(c);
  };
  size_t bytes = header_end_ + 2;
  for (int r = r0; r < r1; ++r) {
    for (int c = c0; c < c1; ++c) bytes += seg_end_[segment(r, c)] - seg_begin_[segment(r, c)] + 2;
  }
  out->clear();
  out->reserve(bytes);
  out->insert(out->end(), data_, data_ + header_end_);
  (*out)[height_offset_] = static_cast<uint8_t>(h >> 8);
  (*out)[height_offset_ + 1] = static_cast<uint8_t>(h & 0xFF);
  (*out)[height_offset_ + 2] = static_cast<uint8_t>(w >> 8);
  (*out)[height_offset_ + 3] = static_cast<uint8_t>(w & 0xFF);
  size_t n = 0;  // segments written: renumbered from RST0
  for (int r = r0; r < r1; ++r) {
    for (int c = c0; c < c1; ++c) {
      if (n > 0) {
        out->push_back(0xFF);
        out->push_back(static_cast<uint8_t>(0xD0 + ((n - 1) & 7)));
      }
      out->insert(out->end(), data_ + seg_begin_[segment(r, c)], data_ + seg_end_[segment(r, c)]);
      ++n;
    }
  }
  out->push_back(0xFF);
  out->push_back(0xD9);
  return true;
}

bool JpegRestartIndex::band(int r0, int r1, std::vector<uint8_t>* out) const {
  if (!usable() || r0 < 0 || r1 <= r0 || r1 > mcu_rows_) return false;
  const int64_t m0 = int64_t{r0} * mcus_per_row_, m1 = int64_t{r1} * mcus_per_row_;
  if (m0 % interval_ != 0) return false;
  // The last segment may hold MCUs below the band: the decoder stops at the band's height.
  const size_t s0 = static_cast<size_t>(m0 / interval_);
  const size_t s1 =
      std::min(seg_begin_.size(), static_cast<size_t>((m1 + interval_ - 1) / interval_));
  const int h = std::min(r1 * mcu_h_, height_) - r0 * mcu_h_;
  size_t bytes = header_end_ + 2;
  for (size_t s = s0; s < s1; ++s) bytes += seg_end_[s] - seg_begin_[s] + 2;
  out->clear();
  out->reserve(bytes);
  out->insert(out->end(), data_, data_ + header_end_);
  (*out)[height_offset_] = static_cast<uint8_t>(h >> 8);
  (*out)[height_offset_ + 1] = static_cast<uint8_t>(h & 0xFF);
  for (size_t s = s0; s < s1; ++s) {
    out->insert(out->end(), data_ + seg_begin_[s], data_ + seg_end_[s]);
    // Renumbered from RST0: the decoder checks the sequence.
    if (s + 1 < s1) {
      out->push_back(0xFF);
      out->push_back(static_cast<uint8_t>(0xD0 + ((s - s0) & 7)));
    }
  }
  out->push_back(0xFF);
  out->push_back(0xD9);
  return true;
}

}  // namespace ptz::perception
