// Settings of a process: a YAML file (OpenCV FileStorage) with every value overridable by a
// flag, and helpers that read structured files with errors naming the file and the field.
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
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

// The values a number may take: lo .. hi, either end open or absent (any finite number by
// default). Declared with a parameter or a field and checked where it is read.
struct Range {
  double lo = -HUGE_VAL, hi = HUGE_VAL;
  bool lo_open = false, hi_open = false;

  static Range atLeast(double v) { return {v, HUGE_VAL, false, false}; }
  static Range above(double v) { return {v, HUGE_VAL, true, false}; }
  static Range atMost(double v) { return {-HUGE_VAL, v, false, false}; }
  static Range below(double v) { return {-HUGE_VAL, v, false, true}; }
  static Range between(double lo, double hi) { return {lo, hi, false, false}; }
  Range andAtMost(double v) const { return {lo, v, lo_open, false}; }
  Range andBelow(double v) const { return {lo, v, lo_open, true}; }

  bool contains(double v) const;
  // "> 0", ">= 1", "0 .. 255", "> 0 and <= 1"; empty for any number.
  std::string text() const;
};

// Opens a YAML/XML file with cv::FileStorage; throws ConfigError naming the file.
cv::FileStorage openForRead(const std::string& path, const std::string& what);

// `where` names the file and the parent of a field: the file alone ("rig file 'x.yaml'", always
// ending in its quoted name) or the file and a path ("rig file 'x.yaml', left.zoom_table[2]").
// The path of `field` inside it: "rig file 'x.yaml', image_width", "..., left.zoom_table[2].zoom".
std::string fieldPath(const std::string& where, const std::string& field);
// Refuses a map with a key not in `known` ("WHERE, objects[0].speed_mps: unknown field (known:
// ...)") and a `node` that is not a map.
void checkFields(const cv::FileNode& node, const std::vector<std::string>& known,
                 const std::string& where);

// Refuses two fields of one parent out of order: "WHERE, pan_min_deg = 10 must be below
// pan_max_deg = 5" (strict; else "must be at most").
void checkFieldOrder(double smaller, double larger, const std::string& where,
                     const std::string& smaller_field, const std::string& larger_field,
                     bool strict = true);

// Reads one field of a structured file. `where` as above; a missing or mistyped field, or a
// number outside its range, throws ConfigError naming the file, the field and the value.
double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  const Range& range = {});
// The same, with a value for a field that is absent.
double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  double fallback, const Range& range = {});
int readInt(const cv::FileNode& parent, const std::string& field, const std::string& where,
            const Range& range = {});
std::string readString(const cv::FileNode& parent, const std::string& field,
                       const std::string& where);
cv::FileNode readNode(const cv::FileNode& parent, const std::string& field,
                      const std::string& where);
// A matrix stored as !!opencv-matrix or as a flat sequence of numbers, checked for its size.
cv::Mat readMatrix(const cv::FileNode& parent, const std::string& field, int rows, int cols,
                   const std::string& where);
// A list of at least `min_count` numbers, each within `range`.
std::vector<double> readNumberList(const cv::FileNode& parent, const std::string& field,
                                   const std::string& where, const Range& range = {},
                                   size_t min_count = 1);
// `count` numbers, each within `range`.
std::vector<double> readNumbers(const cv::FileNode& parent, const std::string& field, size_t count,
                                const std::string& where, const Range& range = {});

// The parameters of one process: declared with default, unit, help and range; read from
// --config FILE, then from flags (--name VALUE or --name=VALUE, dashes or underscores alike).
// Every value is checked against its type and range as it is read, and the declared orders
// (addOrder) once all are read; errors name the source (flag or file), the parameter and the value.
class Params {
 public:
  Params(std::string program, std::string summary);

  void add(const std::string& name, double default_value, const std::string& unit,
           const std::string& help, const Range& range = {});
  void add(const std::string& name, int default_value, const std::string& unit,
           const std::string& help, const Range& range = {});
  void add(const std::string& name, bool default_value, const std::string& help);
  void add(const std::string& name, const char* default_value, const std::string& help);
  // A nested part of the config file (e.g. a list of objects) that flags cannot override.
  void addSection(const std::string& name, const std::string& help);
  // Numeric parameter `smaller` must be below `larger` (or equal, unless strict).
  void addOrder(const std::string& smaller, const std::string& larger, bool strict = true);

  // Returns false when --help was given (usage printed to stdout). Throws ConfigError.
  bool parse(int argc, char** argv);
  // Values already parsed from a config file only (no argv), for tests and tools.
  void parseConfigFile(const std::string& path);
  void set(const std::string& name, const std::string& value);
  // Checks the declared orders (parse and parseConfigFile do; after set(), call it).
  void checkOrders() const;

  // Where a parameter's value came from: "flag --min-range-m", "config file 'x.yaml'" or
  // "default".
  const std::string& sourceOf(const std::string& name) const;
  // A ConfigError for a value the program refuses: "SOURCE: parameter 'NAME' PROBLEM, got 'VALUE'".
  ConfigError invalid(const std::string& name, const std::string& problem) const;

  double getDouble(const std::string& name) const;
  int getInt(const std::string& name) const;
  bool getBool(const std::string& name) const;
  std::string getString(const std::string& name) const;
  // A file a string parameter names, e.g. a model or rig file. A relative path read from the
  // config file is relative to that file's folder (one config folder works from anywhere, an
  // installed one too); from a flag or the default, to the current directory. Empty stays empty.
  std::string getPath(const std::string& name) const;
  // getPath of a file that must exist: else ConfigError naming the source, the parameter, its
  // value and the resolved path. Empty stays empty (for optional files).
  std::string getExistingPath(const std::string& name) const;
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
    Range range;
    std::string source = "default";
    bool from_config = false;  // read from the config file: relative paths from its folder
  };
  struct Order {
    std::string smaller, larger;
    bool strict;
  };
  void addEntry(const std::string& name, Entry e);
  // The range with the declared orders: "> 0; < max_range_m" (for --help and the tables).
  std::string rangeText(const std::string& name) const;
  void readConfigFile(const std::string& path);
  const Entry& entry(const std::string& name) const;
  void setFrom(const std::string& name, const std::string& value, const std::string& source);

  std::string program_;
  std::string summary_;
  std::vector<std::string> order_;
  std::map<std::string, Entry> entries_;
  bool hasSection(const std::string& name) const;
  std::vector<std::pair<std::string, std::string>> sections_;  // (name, help) as declared
  std::vector<Order> orders_;
  std::string config_path_;
  cv::FileStorage config_;
};

}  // namespace ptz
