// Pyramid full scan: a full scan of a wide image (1080p) finds its objects on the image reduced by
// a power of two (a JPEG decoded at that size by libjpeg's IDCT scaling), then detects at full
// resolution only in windows around them, exactly as the windows around tracks do
// (Detector::detectWindow). So its regions are a full-resolution full scan's (same pixels,
// centroids, areas, outlines) for every object the reduced image shows; an object too small to
// survive the reduced image's filters is not found (perception/detect/README.md, Windows).
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "perception/detection/detector.hpp"

namespace ptz::perception {

// The reduction of a full scan of an image width_px wide: the smallest of 2, 4, 8 that brings it
// to max_width_px or less (8 when none does); 1 (no pyramid) when it is that narrow already or
// max_width_px is 0.
int pyramidScale(int width_px, int max_width_px);

// An image of `full` size reduced by `scale`: ceil(width / scale) x ceil(height / scale), the
// size of libjpeg's scaled decode.
cv::Size reducedSize(const cv::Size& full, int scale);

// How far a full-resolution region may reach beyond its candidate's box scaled back (full-image
// px): the reduced image's filters reach exact_margin_px reduced pixels (scale each), its pixels'
// edges blend with the background (less than one reduced pixel), and the full-resolution filters
// reach exact_margin_px.
int pyramidMarginPx(int scale, int exact_margin_px);

// Windows (full-image coordinates) around candidates found in the reduced image: each box scaled
// back by `scale`, grown by margin_px, cut to the image, merged.
std::vector<cv::Rect> pyramidWindows(const std::vector<Region>& candidates, int scale,
                                     int margin_px, const cv::Size& image);

}  // namespace ptz::perception
