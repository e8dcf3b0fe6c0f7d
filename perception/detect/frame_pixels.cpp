#include "perception/detect/frame_pixels.hpp"

#include <opencv2/imgproc.hpp>

#include "common/transport/message_check.hpp"
#include "perception/detection/pyramid.hpp"
#include "perception/jpeg/jpeg_window.hpp"

namespace ptz::perception {

bool decodeRect(const ptzstereo::image_t& m, const cv::Rect& rect, cv::Mat* out, std::string* why) {
  const bool whole = rect == cv::Rect(0, 0, m.width, m.height);
  if (whole || m.encoding != ptzstereo::image_t::ENCODING_JPEG) {
    cv::Mat image;
    if (!decodeImage(m, &image, why)) return false;
    *out = whole ? image : image(rect);
    return true;
  }
  if (!decodeJpegWindow(m.data.data(), m.data.size(), m.width, m.height, rect, out, why))
    return false;
  if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) cv::cvtColor(*out, *out, cv::COLOR_RGB2BGR);
  return true;
}

// The parts `rects` of an image (checked by checkStereoFrame) as BGR: a JPEG's rows and columns of
// them alone, in one pass; the whole image through decodeImage (the same pixels).
bool decodeParts(const ptzstereo::image_t& m, const std::vector<cv::Rect>& rects,
                 std::vector<cv::Mat>* parts, std::string* why) {
  if (rects.size() == 1) {
    parts->resize(1);
    return decodeRect(m, rects[0], &(*parts)[0], why);
  }
  if (m.encoding == ptzstereo::image_t::ENCODING_JPEG) {
    if (!decodeJpegWindows(m.data.data(), m.data.size(), m.width, m.height, rects, parts, why))
      return false;
    if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) {
      for (auto& p : *parts) cv::cvtColor(p, p, cv::COLOR_RGB2BGR);
    }
    return true;
  }
  cv::Mat image;
  if (!decodeImage(m, &image, why)) return false;
  parts->clear();
  for (const auto& r : rects) parts->push_back(image(r));
  return true;
}

// Rows [row0, row1) of an image (checked by checkStereoFrame, colour by checkFrameMatchesRig)
// reduced by `scale` as BGR (DecodeReduced): a JPEG scaled in its decoder from those rows'
// restart segments, raw pixels area-averaged from the message's own bytes.
bool decodeReduced(const ptzstereo::image_t& m, int scale, int row0, int row1, cv::Mat* out,
                   std::string* why) {
  if (m.encoding == ptzstereo::image_t::ENCODING_JPEG) {
    if (!decodeJpegReducedRows(JpegRestartIndex(m.data.data(), m.data.size()), m.width, m.height,
                               scale, row0, row1, out, why)) {
      return false;
    }
  } else {
    if (row0 < 0 || row0 >= row1 || row1 > m.height || row0 % scale != 0) {
      *why = "rows outside the image";
      return false;
    }
    const cv::Mat view(m.height, m.width, CV_8UC3, const_cast<uint8_t*>(m.data.data()),
                       static_cast<size_t>(m.row_stride));
    cv::resize(
        view.rowRange(row0, row1), *out,
        {reducedSize({m.width, m.height}, scale).width, (row1 + scale - 1) / scale - row0 / scale},
        0, 0, cv::INTER_AREA);
  }
  if (m.pixel_format == ptzstereo::image_t::PIXEL_RGB8) cv::cvtColor(*out, *out, cv::COLOR_RGB2BGR);
  return true;
}

ImagePixels FramePixels::pixels() {
  return {[this](const std::vector<cv::Rect>& r, std::vector<cv::Mat>* out, std::string* e) {
            if (!decodeParts(m_, r, out, e)) return false;
            for (size_t i = 0; i < r.size() && i < out->size(); ++i)
              decoded_.emplace_back(r[i], (*out)[i]);
            return true;
          },
          [this](int scale, int row0, int row1, cv::Mat* out, std::string* e) {
            return decodeReduced(m_, scale, row0, row1, out, e);
          }};
}

bool FramePixels::crop(const cv::Rect& rect, cv::Mat* out, bool* reused, std::string* why) const {
  for (const auto& [r, part] : decoded_) {
    if ((r & rect) == rect && part.rows == r.height && part.cols == r.width) {
      *out = part(rect - r.tl());
      *reused = true;
      return true;
    }
  }
  *reused = false;
  return decodeRect(m_, rect, out, why);
}

void cropsOf(FramePixels* left, FramePixels* right, CropPixels crops[2]) {
  FramePixels* pixels[2] = {left, right};
  for (int s = 0; s < 2; ++s) {
    crops[s] = [p = pixels[s]](const cv::Rect& r, cv::Mat* px, std::string* w) {
      bool reused = false;
      return p->crop(r, px, &reused, w);
    };
  }
}

}  // namespace ptz::perception
