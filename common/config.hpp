// Settings of a process: a YAML file (OpenCV FileStorage) with every value overridable by a
// flag, and helpers that read structured files with errors naming the file and the field.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ptz {

// A bad or missing file, field or flag. what() names the file (or flag) and the field.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Opens a YAML/XML file with cv::FileStorage; throws ConfigError naming the file.
cv::FileStorage openForRead(const std::string& path, const std::string& what);

// Reads one field of a structured file. `where` names the file and the parent ("rig file
// 'x.yaml', left"); a missing or mistyped field throws ConfigError naming both.
double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where);
// The same, with a value for a field that is absent.
double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  double fallback);
int readInt(const cv::FileNode& parent, const std::string& field, const std::string& where);
std::string readString(const cv::FileNode& parent, const std::string& field,
                       const std::string& where);
cv::FileNode readNode(const cv::FileNode& parent, const std::string& field,
                      const std::string& where);
// A matrix stored as !!opencv-matrix or as a flat sequence of numbers, checked for its size.
cv::Mat readMatrix(const cv::FileNode& parent, const std::string& field, int rows, int cols,
                   const std::string& where);
std::vector<double> readNumbers(const cv::FileNode& parent, const std::string& field, size_t count,
                                const std::string& where);

// The parameters of one process: declared with default, unit and help; read from --config
// FILE, then from flags (--name VALUE or --name=VALUE, dashes or underscores alike).
class Params {
 public:
  Params(std::string program, std::string summary);

  void add(const std::string& name, double default_value, const std::string& unit,
           const std::string& help);
  void add(const std::string& name, int default_value, const std::string& unit,
           const std::string& help);
  void add(const std::string& name, bool default_value, const std::string& help);
  void add(const std::string& name, const char* default_value, const std::string& help);
  // A nested part of the config file (e.g. a list of objects) that flags cannot override.
  void addSection(const std::string& name, const std::string& help);

  // Returns false when --help was given (usage printed to stdout). Throws ConfigError.
  bool parse(int argc, char** argv);
  // Values already parsed from a config file only (no argv), for tests and tools.
  void parseConfigFile(const std::string& path);
  void set(const std::string& name, const std::string& value);

  double getDouble(const std::string& name) const;
  int getInt(const std::string& name) const;
  bool getBool(const std::string& name) const;
  std::string getString(const std::string& name) const;
  // A section of the config file (none() when absent).
  cv::FileNode section(const std::string& name) const;
  const std::string& configPath() const { return config_path_; }
  const std::string& program() const { return program_; }

  std::string usage() const;
  // A Markdown table of all parameters (for the folder READMEs).
  std::string markdownTable() const;

 private:
  enum class Type { kDouble, kInt, kBool, kString };
  struct Entry {
    Type type;
    std::string value;
    std::string default_value;
    std::string unit;
    std::string help;
  };
  const Entry& entry(const std::string& name) const;
  void setFrom(const std::string& name, const std::string& value, const std::string& source);

  std::string program_;
  std::string summary_;
  std::vector<std::string> order_;
  std::map<std::string, Entry> entries_;
  bool hasSection(const std::string& name) const;
  std::vector<std::pair<std::string, std::string>> sections_;  // (name, help) as declared
  std::string config_path_;
  cv::FileStorage config_;
};

}  // namespace ptz
