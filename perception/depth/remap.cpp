#include "perception/depth/remap.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define PTZ_REMAP_SSSE3 1
#include <tmmintrin.h>
#endif

namespace ptz::perception {
namespace {

#ifdef PTZ_REMAP_SSSE3

// One pixel as cv::remap computes it. OpenCV's fixed-point weights are 32 times the exact
// products (32 - fx)(32 - fy), fx (32 - fy), ... of these fractions (but for (0, 0), where
// 32767 and 1 round the same), so the rounding below is OpenCV's. Neighbours outside are 0.
inline uint8_t bilinear(const cv::Mat& src, int sx, int sy, int frac) {
  const int fx = frac & 31, fy = (frac >> 5) & 31;
  int p0, p1, p2, p3;
  if (static_cast<unsigned>(sx) < static_cast<unsigned>(src.cols - 1) &&
      static_cast<unsigned>(sy) < static_cast<unsigned>(src.rows - 1)) {
    const uint8_t* p = src.ptr<uint8_t>(sy) + sx;
    p0 = p[0];
    p1 = p[1];
    p2 = p[src.step];
    p3 = p[src.step + 1];
  } else {
    const auto at = [&src](int x, int y) -> int {
      const bool inside = static_cast<unsigned>(x) < static_cast<unsigned>(src.cols) &&
                          static_cast<unsigned>(y) < static_cast<unsigned>(src.rows);
      return inside ? src.ptr<uint8_t>(y)[x] : 0;
    };
    p0 = at(sx, sy);
    p1 = at(sx + 1, sy);
    p2 = at(sx, sy + 1);
    p3 = at(sx + 1, sy + 1);
  }
  const int top = p0 * 32 + (p1 - p0) * fx, bottom = p2 * 32 + (p3 - p2) * fx;
  return static_cast<uint8_t>((top * 32 + (bottom - top) * fy + 512) >> 10);
}

// Rows [y0, y1) of dst; needs src.cols >= 16. Runs of 8 pixels whose sources lie within 16
// columns and two adjacent row pairs take the vector path, the rest the scalar one.
__attribute__((target("ssse3"))) void remapRowsSsse3(const cv::Mat& src, const cv::Mat& map_xy,
                                                     const cv::Mat& map_frac, cv::Mat* dst, int y0,
                                                     int y1) {
  const size_t step = src.step;
  const int max_base_x = src.cols - 16;
  // Splits 4 (x, y) pairs of int16 into 4 x then 4 y.
  const __m128i split = _mm_setr_epi8(0, 1, 4, 5, 8, 9, 12, 13, 2, 3, 6, 7, 10, 11, 14, 15);
  const __m128i k0101 = _mm_set1_epi16(0x0101), k0100 = _mm_set1_epi16(0x0100);
  const __m128i k31 = _mm_set1_epi16(31), k32 = _mm_set1_epi16(32), k14 = _mm_set1_epi16(14);
  const __m128i k1 = _mm_set1_epi16(1), k0 = _mm_setzero_si128();
  const __m128i half = _mm_set1_epi32(512);
  for (int y = y0; y < y1; ++y) {
    const int16_t* xy = map_xy.ptr<int16_t>(y);
    const uint16_t* frac = map_frac.ptr<uint16_t>(y);
    uint8_t* out = dst->ptr<uint8_t>(y);
    int x = 0;
    for (; x + 8 <= dst->cols; x += 8) {
      const int16_t* p = xy + 2 * x;
      const __m128i a =
          _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)), split);
      const __m128i b =
          _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 8)), split);
      const __m128i sx = _mm_unpacklo_epi64(a, b), sy = _mm_unpackhi_epi64(a, b);
      const int base_x = std::clamp(p[0] - 1, 0, max_base_x);
      const int base_y = std::min(p[1], p[15]);  // first and last pixel's rows
      const __m128i dx = _mm_sub_epi16(sx, _mm_set1_epi16(static_cast<int16_t>(base_x)));
      const __m128i dy = _mm_sub_epi16(sy, _mm_set1_epi16(static_cast<int16_t>(base_y)));
      const __m128i outside =
          _mm_or_si128(_mm_or_si128(_mm_cmpgt_epi16(dx, k14), _mm_cmplt_epi16(dx, k0)),
                       _mm_or_si128(_mm_cmpgt_epi16(dy, k1), _mm_cmplt_epi16(dy, k0)));
      const __m128i lower = _mm_cmpeq_epi16(dy, k1);  // pixels on the second row pair
      const bool two_pairs = _mm_movemask_epi8(lower) != 0;
      if (_mm_movemask_epi8(outside) != 0 || base_y < 0 ||
          base_y + (two_pairs ? 1 : 0) > src.rows - 2) {
        for (int k = 0; k < 8; ++k) out[x + k] = bilinear(src, p[2 * k], p[2 * k + 1], frac[x + k]);
        continue;
      }
      // Each pixel's left and right neighbour as the low and high byte of a 16-bit lane.
      const __m128i pick = _mm_add_epi16(_mm_mullo_epi16(dx, k0101), k0100);
      const uint8_t* row = src.ptr<uint8_t>(base_y) + base_x;
      const __m128i r0 =
          _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row)), pick);
      const __m128i r1 =
          _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + step)), pick);
      __m128i upper = r0, under = r1;
      if (two_pairs) {
        const __m128i r2 = _mm_shuffle_epi8(
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + 2 * step)), pick);
        upper = _mm_or_si128(_mm_andnot_si128(lower, r0), _mm_and_si128(lower, r1));
        under = _mm_or_si128(_mm_andnot_si128(lower, r1), _mm_and_si128(lower, r2));
      }
      const __m128i f = _mm_loadu_si128(reinterpret_cast<const __m128i*>(frac + x));
      const __m128i fx = _mm_and_si128(f, k31), fy = _mm_and_si128(_mm_srli_epi16(f, 5), k31);
      // (32 - fx, fx) as byte pairs: top = p0 (32 - fx) + p1 fx, <= 8160.
      const __m128i wx = _mm_or_si128(_mm_sub_epi16(k32, fx), _mm_slli_epi16(fx, 8));
      const __m128i top = _mm_maddubs_epi16(upper, wx), bottom = _mm_maddubs_epi16(under, wx);
      const __m128i wy = _mm_sub_epi16(k32, fy);
      __m128i lo = _mm_madd_epi16(_mm_unpacklo_epi16(top, bottom), _mm_unpacklo_epi16(wy, fy));
      __m128i hi = _mm_madd_epi16(_mm_unpackhi_epi16(top, bottom), _mm_unpackhi_epi16(wy, fy));
      lo = _mm_srai_epi32(_mm_add_epi32(lo, half), 10);
      hi = _mm_srai_epi32(_mm_add_epi32(hi, half), 10);
      const __m128i v = _mm_packs_epi32(lo, hi);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(out + x), _mm_packus_epi16(v, v));
    }
    for (; x < dst->cols; ++x) out[x] = bilinear(src, xy[2 * x], xy[2 * x + 1], frac[x]);
  }
}

#endif

}  // namespace

bool remapGreyHasSimd() {
#ifdef PTZ_REMAP_SSSE3
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("ssse3") != 0;
  }();
  return has;
#else
  return false;
#endif
}

void remapGreyRows(const cv::Mat& src, const cv::Mat& map_xy, const cv::Mat& map_frac, cv::Mat* dst,
                   int y0, int y1, bool simd) {
  CV_Assert(src.type() == CV_8UC1 && map_xy.type() == CV_16SC2 && map_frac.type() == CV_16UC1 &&
            map_xy.size() == map_frac.size() && dst->type() == CV_8UC1 &&
            dst->size() == map_xy.size() && dst->data != src.data && 0 <= y0 && y0 <= y1 &&
            y1 <= dst->rows);
#ifdef PTZ_REMAP_SSSE3
  if (simd && remapGreyHasSimd() && src.cols >= 16 && src.rows >= 2) {
    remapRowsSsse3(src, map_xy, map_frac, dst, y0, y1);
    return;
  }
#endif
  (void)simd;
  cv::Mat rows = dst->rowRange(y0, y1);
  cv::remap(src, rows, map_xy.rowRange(y0, y1), map_frac.rowRange(y0, y1), cv::INTER_LINEAR);
}

void remapGrey(const cv::Mat& src, const cv::Mat& map_xy, const cv::Mat& map_frac, cv::Mat* dst,
               bool simd) {
  dst->create(map_xy.size(), CV_8UC1);
  // Stripes as cv::remap makes them.
  cv::parallel_for_(
      cv::Range(0, dst->rows),
      [&](const cv::Range& rows) {
        remapGreyRows(src, map_xy, map_frac, dst, rows.start, rows.end, simd);
      },
      static_cast<double>(dst->total()) / (1 << 16));
}

}  // namespace ptz::perception
