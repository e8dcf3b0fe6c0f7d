// Random access into a baseline JPEG by its restart markers: an entropy-coded segment after a
// restart marker decodes alone (DC predictions and the bit reader start afresh), so the MCU rows a
// window needs can be decoded without entropy-decoding the rows above them (which
// jpeg_skip_scanlines must do). The index finds the segments once per image; band() assembles a
// small JPEG of a few MCU rows (the header with its height patched, their segments renumbered
// from RST0, EOI) that libjpeg decodes to the same pixels as those rows of the whole image. When
// the segments split each MCU row evenly (encodeImage: 8 MCUs, 128 px), tile() does the same for
// a few of the row's segments, so a window's columns are decoded without the rest of its rows.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ptz::perception {

class JpegRestartIndex {
 public:
  // No index: every decode takes the whole stream from its top.
  JpegRestartIndex() = default;
  // Indexes the bytes (not copied: they must outlive the index). Unusable, silently, unless the
  // JPEG is baseline Huffman (SOF0/SOF1) with 3 components in one interleaved scan, a restart
  // interval, and exactly the expected restart markers in sequence, each segment non-empty, then
  // EOI. Every offset is checked against `size`; the index holds at most size / 2 segments.
  // use_restarts false: the bytes alone, unusable (the whole-stream path, for comparisons).
  JpegRestartIndex(const uint8_t* data, size_t size, bool use_restarts = true);

  bool usable() const { return !seg_begin_.empty(); }
  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int mcuHeight() const { return mcu_h_; }  // pixels; MCU rows are 0 .. mcuRows() - 1
  int mcuRows() const { return mcu_rows_; }
  // The last MCU row <= row at which a segment begins (a band can start there).
  int bandStart(int row) const;
  // A JPEG of MCU rows [r0, r1) (r0 from bandStart, r0 < r1 <= mcuRows()): width() x
  // min(r1 * mcuHeight(), height()) - r0 * mcuHeight() pixels. False when unusable.
  bool band(int r0, int r1, std::vector<uint8_t>* out) const;
  // Segments to an MCU row when they split it evenly, else 1 (a segment is then a row or more);
  // the pixels of one (the last may hold fewer of the image's).
  int tilesPerRow() const { return tiles_per_row_; }
  int tileWidth() const { return tile_w_; }
  // A JPEG of MCU rows [r0, r1) and tiles [c0, c1) of each (0 <= c0 < c1 <= tilesPerRow()):
  // min(c1 * tileWidth(), width()) - c0 * tileWidth() pixels wide, as band() otherwise (band()
  // itself when a segment is a row or more). False when unusable.
  bool tile(int r0, int r1, int c0, int c1, std::vector<uint8_t>* out) const;

 private:
  bool index();

  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  int width_ = 0, height_ = 0;
  int mcu_h_ = 0, mcus_per_row_ = 0, mcu_rows_ = 0;
  int64_t interval_ = 0;      // MCUs per segment (DRI)
  size_t header_end_ = 0;     // the first byte after the SOS segment
  size_t height_offset_ = 0;  // of the SOF's 16-bit height (its width follows)
  int tiles_per_row_ = 1, tile_w_ = 0;
  std::vector<uint32_t> seg_begin_, seg_end_;  // [begin, end): a segment without its marker
};

}  // namespace ptz::perception
