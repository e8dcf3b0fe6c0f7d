#include "common/config.hpp"

#include "common/storage_guard.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace ptz {
namespace {

std::string normalise(std::string name) {
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

std::string formatDouble(double v) {
  std::ostringstream s;
  s << std::setprecision(12) << v;
  return s.str();
}

std::string nodeToString(const cv::FileNode& n) {
  if (n.isInt()) return std::to_string(static_cast<int>(n));
  if (n.isReal()) return formatDouble(static_cast<double>(n));
  if (n.isString()) return static_cast<std::string>(n);
  return {};
}

}  // namespace

cv::FileStorage openForRead(const std::string& path, const std::string& what) {
  // Checked first so that OpenCV does not log its own error before ours.
  if (!std::ifstream(path).good()) {
    throw ConfigError(what + " '" + path + "': cannot open (missing or unreadable)");
  }
  const std::string problem = yamlTextProblem(path);
  if (!problem.empty()) throw ConfigError(what + " '" + path + "': " + problem);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) {
      throw ConfigError(what + " '" + path + "': cannot open (missing or unreadable)");
    }
    readEveryNode(fs.root());
  } catch (const ConfigError&) {
    throw;
  } catch (const cv::Exception& e) {
    throw ConfigError(what + " '" + path + "': malformed (" + e.err + ")");
  } catch (const std::exception& e) {
    throw ConfigError(what + " '" + path + "': malformed (" + e.what() + ")");
  }
  return fs;
}

bool Range::contains(double v) const {
  if (std::isnan(v)) return false;
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  return hi_open ? v < hi : v <= hi;
}

std::string Range::text() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  const std::string low = (lo_open ? "> " : ">= ") + formatDouble(lo);
  const std::string high = (hi_open ? "< " : "<= ") + formatDouble(hi);
  if (has_lo && has_hi) {
    if (!lo_open && !hi_open) return formatDouble(lo) + " .. " + formatDouble(hi);
    return low + " and " + high;
  }
  if (has_lo) return low;
  if (has_hi) return high;
  return "";
}

namespace {
// "must be > 0, got '-1'" (empty when the value is in range).
std::string rangeProblem(const Range& range, double v, const std::string& text) {
  if (range.contains(v)) return "";
  const std::string r = range.text();
  return "must be " + (r.find("..") != std::string::npos ? "within " + r : r) + ", got '" + text +
         "'";
}

// What a node holds, for an error message: its value, or what kind of node it is.
std::string describe(const cv::FileNode& n) {
  if (n.isSeq()) return "a list";
  if (n.isMap()) return "a map";
  const std::string text = nodeToString(n);
  return "'" + text + "'";
}
}  // namespace

std::string fieldPath(const std::string& where, const std::string& field) {
  return where + (!where.empty() && where.back() == '\'' ? ", " : ".") + field;
}

void checkFields(const cv::FileNode& node, const std::vector<std::string>& known,
                 const std::string& where) {
  if (!node.isMap()) throw ConfigError(where + ": must be a map of fields, got " + describe(node));
  for (const auto& child : node) {
    const std::string key = child.name();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    throw ConfigError(fieldPath(where, key) + ": unknown field (known: " + list + ")");
  }
}

void checkFieldOrder(double smaller, double larger, const std::string& where,
                     const std::string& smaller_field, const std::string& larger_field,
                     bool strict) {
  if (strict ? smaller < larger : smaller <= larger) return;
  throw ConfigError(fieldPath(where, smaller_field) + " = " + formatDouble(smaller) + " must be " +
                    (strict ? "below " : "at most ") + larger_field + " = " + formatDouble(larger));
}

cv::FileNode readNode(const cv::FileNode& parent, const std::string& field,
                      const std::string& where) {
  cv::FileNode n = parent.isMap() ? parent[field] : cv::FileNode();
  if (n.empty() || n.isNone()) throw ConfigError(where + ": missing field '" + field + "'");
  return n;
}

double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  const Range& range) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isReal() && !n.isInt()) {
    throw ConfigError(fieldPath(where, field) + ": must be a number, got " + describe(n));
  }
  double v = static_cast<double>(n);
  if (!std::isfinite(v)) {
    throw ConfigError(fieldPath(where, field) + ": must be finite, got '" + formatDouble(v) + "'");
  }
  const std::string problem = rangeProblem(range, v, formatDouble(v));
  if (!problem.empty()) throw ConfigError(fieldPath(where, field) + ": " + problem);
  return v;
}

double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  double fallback, const Range& range) {
  return parent[field].empty() ? fallback : readDouble(parent, field, where, range);
}

int readInt(const cv::FileNode& parent, const std::string& field, const std::string& where,
            const Range& range) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isInt()) {
    throw ConfigError(fieldPath(where, field) + ": must be an integer, got " + describe(n));
  }
  const int v = static_cast<int>(n);
  const std::string problem = rangeProblem(range, v, std::to_string(v));
  if (!problem.empty()) throw ConfigError(fieldPath(where, field) + ": " + problem);
  return v;
}

std::string readString(const cv::FileNode& parent, const std::string& field,
                       const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isString()) {
    throw ConfigError(fieldPath(where, field) + ": must be a string, got " + describe(n));
  }
  return static_cast<std::string>(n);
}

std::vector<double> readNumberList(const cv::FileNode& parent, const std::string& field,
                                   const std::string& where, const Range& range, size_t min_count) {
  cv::FileNode n = readNode(parent, field, where);
  const std::string path = fieldPath(where, field);
  if (!n.isSeq() || n.size() < min_count) {
    throw ConfigError(path + ": must be a list of at least " + std::to_string(min_count) +
                      " numbers, got " + (n.isSeq() ? std::to_string(n.size()) : describe(n)));
  }
  std::vector<double> out;
  for (const auto& item : n) {
    const std::string at = path + "[" + std::to_string(out.size()) + "]";
    if (!item.isReal() && !item.isInt()) {
      throw ConfigError(at + ": must be a number, got " + describe(item));
    }
    const double v = static_cast<double>(item);
    if (!std::isfinite(v))
      throw ConfigError(at + ": must be finite, got '" + formatDouble(v) + "'");
    const std::string problem = rangeProblem(range, v, formatDouble(v));
    if (!problem.empty()) throw ConfigError(at + ": " + problem);
    out.push_back(v);
  }
  return out;
}

std::vector<double> readNumbers(const cv::FileNode& parent, const std::string& field, size_t count,
                                const std::string& where, const Range& range) {
  const cv::FileNode n = readNode(parent, field, where);
  if (!n.isSeq() || n.size() != count) {
    throw ConfigError(fieldPath(where, field) + ": must be a list of " + std::to_string(count) +
                      " numbers, got " + (n.isSeq() ? std::to_string(n.size()) : describe(n)));
  }
  return readNumberList(parent, field, where, range, count);
}

cv::Mat readMatrix(const cv::FileNode& parent, const std::string& field, int rows, int cols,
                   const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  cv::Mat m;
  if (n.isSeq()) {
    auto v = readNumbers(parent, field, static_cast<size_t>(rows * cols), where);
    return cv::Mat(v, true).reshape(1, rows);
  }
  // OpenCV allocates rows x cols before it reads the data: a few bytes could ask for gigabytes
  // (found by fuzz/fuzz_rig). Sizes and data are checked first; one channel only.
  bool sized = false;
  if (n.isMap()) {  // operator[] asserts on anything else (found by fuzz/fuzz_rig too)
    const cv::FileNode file_rows = n["rows"], file_cols = n["cols"], data = n["data"];
    sized = file_rows.isInt() && file_cols.isInt() && n["dt"].isString() && data.isSeq() &&
            static_cast<int>(file_rows) >= 1 && static_cast<int>(file_cols) >= 1 &&
            int64_t{static_cast<int>(file_rows)} * static_cast<int>(file_cols) ==
                int64_t{rows} * cols &&
            data.size() == static_cast<size_t>(rows * cols);
  }
  try {
    if (sized) n >> m;
  } catch (const cv::Exception&) {
    m.release();
  }
  if (m.empty() || m.channels() != 1 || m.total() != static_cast<size_t>(rows * cols)) {
    throw ConfigError(fieldPath(where, field) + ": must be a " + std::to_string(rows) + "x" +
                      std::to_string(cols) + " matrix");
  }
  m.convertTo(m, CV_64F);
  if (!cv::checkRange(m)) throw ConfigError(fieldPath(where, field) + ": must be finite");
  return m.reshape(1, rows);
}

Params::Params(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {
  add("config", "", "YAML config file (OpenCV FileStorage); flags override its values");
}

void Params::addEntry(const std::string& name, Entry e) {
  if (e.type == Type::kDouble || e.type == Type::kInt) {
    if (!e.range.contains(std::stod(e.value))) {
      throw std::logic_error(program_ + ": default of " + name + " outside its range");
    }
  }
  order_.push_back(name);
  entries_[name] = std::move(e);
}

void Params::add(const std::string& name, double v, const std::string& unit,
                 const std::string& help, const Range& range) {
  addEntry(name, {Type::kDouble, formatDouble(v), formatDouble(v), unit, help, range});
}
void Params::add(const std::string& name, int v, const std::string& unit, const std::string& help,
                 const Range& range) {
  addEntry(name, {Type::kInt, std::to_string(v), std::to_string(v), unit, help, range});
}
void Params::add(const std::string& name, bool v, const std::string& help) {
  addEntry(name, {Type::kBool, v ? "true" : "false", v ? "true" : "false", "", help, {}});
}
void Params::add(const std::string& name, const char* v, const std::string& help) {
  addEntry(name, {Type::kString, v, v, "", help, {}});
}
void Params::addSection(const std::string& name, const std::string& help) {
  if (!hasSection(name)) sections_.emplace_back(name, help);
}

void Params::addOrder(const std::string& smaller, const std::string& larger, bool strict) {
  for (const auto* name : {&smaller, &larger}) {
    const Type t = entry(*name).type;
    if (t != Type::kDouble && t != Type::kInt) {
      throw std::logic_error(program_ + ": order of a non-numeric parameter " + *name);
    }
  }
  orders_.push_back({smaller, larger, strict});
}

void Params::checkOrders() const {
  for (const auto& o : orders_) {
    const double a = getDouble(o.smaller), b = getDouble(o.larger);
    if (o.strict ? a < b : a <= b) continue;
    auto named = [&](const std::string& name) {
      const Entry& e = entry(name);
      return "parameter '" + name + "' = " + e.value + " (" + e.source + ")";
    };
    throw ConfigError(named(o.smaller) + " must be " + (o.strict ? "below " : "at most ") +
                      named(o.larger));
  }
}

std::string Params::rangeText(const std::string& name) const {
  std::string text = entry(name).range.text();
  for (const auto& o : orders_) {
    std::string order;
    if (o.smaller == name) order = (o.strict ? "< " : "<= ") + o.larger;
    if (o.larger == name) order = (o.strict ? "> " : ">= ") + o.smaller;
    if (!order.empty()) text += (text.empty() ? "" : "; ") + order;
  }
  return text;
}

const std::string& Params::sourceOf(const std::string& name) const {
  return entry(name).source;
}

ConfigError Params::invalid(const std::string& name, const std::string& problem) const {
  const Entry& e = entry(name);
  return ConfigError(e.source + ": parameter '" + name + "' " + problem + ", got '" + e.value +
                     "'");
}

bool Params::hasSection(const std::string& name) const {
  return std::any_of(sections_.begin(), sections_.end(),
                     [&](const auto& section) { return section.first == name; });
}

const Params::Entry& Params::entry(const std::string& name) const {
  auto it = entries_.find(name);
  if (it == entries_.end()) throw std::logic_error(program_ + ": undeclared parameter " + name);
  return it->second;
}

void Params::setFrom(const std::string& raw_name, const std::string& value,
                     const std::string& source) {
  const std::string name = normalise(raw_name);
  auto it = entries_.find(name);
  if (it == entries_.end()) {
    throw ConfigError(source + ": unknown parameter '" + raw_name + "' (see " + program_ +
                      " --help)");
  }
  Entry& e = it->second;
  std::string v = value;
  char* end = nullptr;
  switch (e.type) {
    case Type::kDouble: {
      errno = 0;
      double d = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !std::isfinite(d) || errno == ERANGE) {
        throw ConfigError(source + ": parameter '" + name + "' must be a finite number, got '" + v +
                          "'");
      }
      break;
    }
    case Type::kInt: {
      long i = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || i < INT32_MIN || i > INT32_MAX) {
        throw ConfigError(source + ": parameter '" + name + "' must be an integer, got '" + v +
                          "'");
      }
      break;
    }
    case Type::kBool:
      if (v == "1" || v == "true" || v == "on" || v == "yes") {
        v = "true";
      } else if (v == "0" || v == "false" || v == "off" || v == "no") {
        v = "false";
      } else {
        throw ConfigError(source + ": parameter '" + name + "' must be true or false, got '" + v +
                          "'");
      }
      break;
    case Type::kString:
      break;
  }
  if (e.type == Type::kDouble || e.type == Type::kInt) {
    const std::string problem = rangeProblem(e.range, std::strtod(v.c_str(), nullptr), v);
    if (!problem.empty()) throw ConfigError(source + ": parameter '" + name + "' " + problem);
  }
  e.value = v;
  e.source = source;
  e.from_config = false;
}

void Params::set(const std::string& name, const std::string& value) {
  setFrom(name, value, "set");
}

void Params::parseConfigFile(const std::string& path) {
  readConfigFile(path);
  checkOrders();
}

void Params::readConfigFile(const std::string& path) {
  config_path_ = path;
  config_ = openForRead(path, "config file");
  const std::string where = "config file '" + path + "'";
  cv::FileNode root = config_.root();
  // Only a map's children have names (OpenCV asserts otherwise; found by fuzz/fuzz_config).
  if (!root.isMap() && !root.isNone()) {
    throw ConfigError(where + ": must be a map of parameters, got " +
                      (root.isSeq() ? std::string("a list") : "'" + nodeToString(root) + "'"));
  }
  for (const auto& node : root) {
    const std::string key = node.name();
    if (hasSection(key)) continue;
    if (!entries_.count(normalise(key)) || key == "config") {
      throw ConfigError(where + ": unknown field '" + key + "' (see " + program_ + " --help)");
    }
    std::string text = nodeToString(node);
    if (text.empty() && !node.isString()) {
      throw ConfigError(where + ": field '" + key + "' must be a single value");
    }
    setFrom(key, text, where);
    entries_[normalise(key)].from_config = true;
  }
}

bool Params::parse(int argc, char** argv) {
  std::vector<std::pair<std::string, std::string>> flags;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::fputs(usage().c_str(), stdout);
      return false;
    }
    if (arg == "--help-markdown") {  // the parameter table of the folder READMEs
      std::fputs(markdownTable().c_str(), stdout);
      return false;
    }
    if (arg.rfind("--", 0) != 0) throw ConfigError("unexpected argument '" + arg + "'");
    arg = arg.substr(2);
    std::string value;
    auto eq = arg.find('=');
    if (eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    } else {
      auto it = entries_.find(normalise(arg));
      if (it != entries_.end() && it->second.type == Type::kBool &&
          (i + 1 >= argc || std::string(argv[i + 1]).rfind("--", 0) == 0)) {
        value = "true";  // a bare boolean flag
      } else if (i + 1 < argc) {
        value = argv[++i];
      } else {
        throw ConfigError("flag --" + arg + " needs a value");
      }
    }
    flags.emplace_back(arg, value);
  }
  for (const auto& [name, value] : flags) {
    if (normalise(name) == "config") readConfigFile(value);
  }
  for (const auto& [name, value] : flags) {
    if (normalise(name) != "config") setFrom(name, value, "flag --" + name);
  }
  checkOrders();
  return true;
}

double Params::getDouble(const std::string& name) const {
  return std::stod(entry(name).value);
}
int Params::getInt(const std::string& name) const {
  return std::stoi(entry(name).value);
}
bool Params::getBool(const std::string& name) const {
  return entry(name).value == "true";
}
std::string Params::getString(const std::string& name) const {
  return entry(name).value;
}

std::string Params::getPath(const std::string& name) const {
  const Entry& e = entry(name);
  const std::filesystem::path value(e.value);
  if (e.value.empty() || value.is_absolute() || !e.from_config) return e.value;
  return (std::filesystem::path(config_path_).parent_path() / value).lexically_normal().string();
}

std::string Params::getExistingPath(const std::string& name) const {
  const std::string path = getPath(name);
  std::error_code ec;
  if (path.empty() || std::filesystem::is_regular_file(path, ec)) return path;
  const Entry& e = entry(name);
  std::string problem = std::filesystem::exists(path, ec) ? "is not a file" : "does not exist";
  if (path != e.value) problem += " (relative paths in a config file are from its folder)";
  throw ConfigError(e.source + ": parameter '" + name + "' = '" + e.value + "': '" + path + "' " +
                    problem);
}

cv::FileNode Params::section(const std::string& name) const {
  if (!config_.isOpened()) return cv::FileNode();
  return config_[name];
}

std::string Params::usage() const {
  std::ostringstream s;
  s << "Usage: " << program_ << " [--config FILE] [--name VALUE ...]\n\n" << summary_ << "\n\n";
  s << "Parameters (config file keys; each also a flag --name):\n";
  for (const auto& name : order_) {
    const Entry& e = entries_.at(name);
    std::string head = "  --" + name;
    if (!e.unit.empty()) head += " [" + e.unit + "]";
    s << std::left << std::setw(36) << head << " " << e.help;
    const std::string range = rangeText(name);
    if (!e.default_value.empty() || !range.empty()) {
      s << " (";
      if (!e.default_value.empty()) s << "default " << e.default_value;
      if (!e.default_value.empty() && !range.empty()) s << "; ";
      if (!range.empty()) s << range;
      s << ")";
    }
    s << "\n";
  }
  for (const auto& [name, help] : sections_) {
    s << "  " << std::left << std::setw(35) << (name + ":") << " " << help
      << " (config file only)\n";
  }
  return s.str();
}

std::string Params::markdownTable() const {
  std::ostringstream s;
  s << "| parameter | unit | default | range | meaning |\n|---|---|---|---|---|\n";
  // A '|' inside a cell would end it.
  auto cell = [](const std::string& text) {
    std::string out;
    for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  for (const auto& name : order_) {
    const Entry& e = entries_.at(name);
    s << "| `" << name << "` | " << e.unit << " | " << cell(e.default_value) << " | "
      << rangeText(name) << " | " << cell(e.help) << " |\n";
  }
  for (const auto& [name, help] : sections_) {
    s << "| `" << name << ":` (section) |  |  |  | " << cell(help) << " |\n";
  }
  return s.str();
}

}  // namespace ptz
