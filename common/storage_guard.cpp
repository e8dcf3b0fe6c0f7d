#include "common/storage_guard.hpp"

#include <fstream>
#include <set>
#include <stdexcept>

namespace ptz {

std::string yamlTextProblem(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  int number = 0;
  auto malformed = [&](const std::string& what) {
    return "malformed (line " + std::to_string(number) + ": " + what + ")";
  };
  bool yaml = false, marker = false, body = false;
  while (std::getline(in, line)) {
    ++number;
    if (!yaml) {
      const size_t first = line.find_first_not_of(" \r");
      if (first == std::string::npos) continue;
      if (line.compare(first, 5, "%YAML") != 0) return malformed("not YAML: no %YAML:1.0 first");
      yaml = true;
    }
    for (unsigned char c : line) {
      if (c < 0x20 && c != '\t' && c != '\r') {
        return malformed("a control character, byte " + std::to_string(c) + ": YAML is text");
      }
    }
    line = line.substr(0, line.find('\r'));  // OpenCV ignores what follows a '\r'
    const size_t i = line.find_first_not_of(' ');
    if (i == std::string::npos || line[i] == '#') continue;
    const bool dashes = line.compare(i, 3, "---") == 0, dots = line.compare(i, 3, "...") == 0;
    if (body) {
      if (i == 0 && (dashes || dots)) return malformed("a second document: one per file");
      continue;
    }
    if (i == 0 && line[i] == '%')
      continue;  // a directive (in column 1 only: indented, the parser loops)
    if (dashes && !marker) {
      const size_t rest = line.find_first_not_of(' ', i + 3);
      if (rest != std::string::npos && line[rest] != '#') {
        return malformed("content after '---': start the top level on the next line");
      }
      marker = true;
      continue;
    }
    if (line[i] == '{' || line[i] == '[') {
      return malformed("the top level in flow style: write it as a block map");
    }
    if (dashes || dots) return malformed("a second document: one per file");
    if (i != 0) return malformed("the top level is indented: it must start in column 1");
    body = true;
  }
  return yaml ? "" : "empty (not YAML: no %YAML:1.0 first)";
}

namespace {

void readEveryNodeAt(const cv::FileNode& node, const std::string& path) {
  if (node.isMap()) {
    std::set<std::string> keys;
    for (const auto& child : node) {
      const std::string key = child.name();
      const std::string child_path = path.empty() ? key : path + "." + key;
      if (!keys.insert(key).second) {
        throw std::runtime_error(child_path + ": given twice; a map's keys are unique");
      }
      readEveryNodeAt(child, child_path);
    }
  } else if (node.isSeq()) {
    size_t i = 0;
    for (const auto& child : node) readEveryNodeAt(child, path + "[" + std::to_string(i++) + "]");
  } else if (node.isString()) {
    (void)node.string();
  }
}

}  // namespace

void readEveryNode(const cv::FileNode& node) {
  readEveryNodeAt(node, "");
}

}  // namespace ptz
