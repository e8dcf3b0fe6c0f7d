// Guards around OpenCV 4.6's FileStorage parser, which every config, rig and model file goes
// through (openForRead). Found by the fuzz targets of fuzz/: the parser can loop forever or crash
// on a few bytes, accept a file and throw later when a node is read, or allocate a matrix's
// declared size before it reads the data (readMatrix checks that).
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace ptz {

// What makes the file at `path` unfit for OpenCV's parser, or "" when it is YAML text it
// handles. Only YAML: OpenCV's XML reader crashed on a few bytes (a NULL dereference), and the
// project writes and documents YAML alone. Refused: a file that does not begin with %YAML, a
// control character (a NUL makes the parser lose its place in the line), and the layouts on
// which it loops forever looking for a second document it never moves past: a top level that is
// indented, in flow style or after content on the '---' line, a '...' or a second '---' (a '%'
// directive counts only in column 1: an indented one is an indented top level).
std::string yamlTextProblem(const std::string& path);

// Reads every key and every text of the tree once: the parser can leave a node whose name or text
// is broken and throws (cv::Exception, std::length_error) only when it is read. A key given twice
// in one map throws std::runtime_error naming its path ("left.zoom: given twice ..."): OpenCV
// keeps both and a lookup finds the first, so a value added below an old one would be ignored.
void readEveryNode(const cv::FileNode& node);

}  // namespace ptz
