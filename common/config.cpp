#include "common/config.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
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
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) {
      throw ConfigError(what + " '" + path + "': cannot open (missing or unreadable)");
    }
  } catch (const cv::Exception& e) {
    throw ConfigError(what + " '" + path + "': malformed (" + e.err + ")");
  }
  return fs;
}

cv::FileNode readNode(const cv::FileNode& parent, const std::string& field,
                      const std::string& where) {
  cv::FileNode n = parent.isMap() ? parent[field] : cv::FileNode();
  if (n.empty() || n.isNone()) throw ConfigError(where + ": missing field '" + field + "'");
  return n;
}

double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isReal() && !n.isInt())
    throw ConfigError(where + ": field '" + field + "' must be a number");
  double v = static_cast<double>(n);
  if (!std::isfinite(v)) throw ConfigError(where + ": field '" + field + "' is not finite");
  return v;
}

double readDouble(const cv::FileNode& parent, const std::string& field, const std::string& where,
                  double fallback) {
  return parent[field].empty() ? fallback : readDouble(parent, field, where);
}

int readInt(const cv::FileNode& parent, const std::string& field, const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isInt()) throw ConfigError(where + ": field '" + field + "' must be an integer");
  return static_cast<int>(n);
}

std::string readString(const cv::FileNode& parent, const std::string& field,
                       const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  if (!n.isString()) throw ConfigError(where + ": field '" + field + "' must be a string");
  return static_cast<std::string>(n);
}

std::vector<double> readNumbers(const cv::FileNode& parent, const std::string& field, size_t count,
                                const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  std::vector<double> out;
  if (n.isSeq()) {
    for (const auto& item : n) {
      if (!item.isReal() && !item.isInt()) break;
      out.push_back(static_cast<double>(item));
    }
  }
  if (out.size() != count ||
      !std::all_of(out.begin(), out.end(), [](double v) { return std::isfinite(v); })) {
    throw ConfigError(where + ": field '" + field + "' must be a list of " + std::to_string(count) +
                      " finite numbers");
  }
  return out;
}

cv::Mat readMatrix(const cv::FileNode& parent, const std::string& field, int rows, int cols,
                   const std::string& where) {
  cv::FileNode n = readNode(parent, field, where);
  cv::Mat m;
  if (n.isSeq()) {
    auto v = readNumbers(parent, field, static_cast<size_t>(rows * cols), where);
    return cv::Mat(v, true).reshape(1, rows);
  }
  try {
    n >> m;
  } catch (const cv::Exception&) {
    m.release();
  }
  if (m.empty() || m.total() != static_cast<size_t>(rows * cols)) {
    throw ConfigError(where + ": field '" + field + "' must be a " + std::to_string(rows) + "x" +
                      std::to_string(cols) + " matrix");
  }
  m.convertTo(m, CV_64F);
  if (!cv::checkRange(m)) throw ConfigError(where + ": field '" + field + "' is not finite");
  return m.reshape(1, rows);
}

Params::Params(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {
  add("config", "", "YAML config file (OpenCV FileStorage); flags override its values");
}

void Params::add(const std::string& name, double v, const std::string& unit,
                 const std::string& help) {
  order_.push_back(name);
  entries_[name] = {Type::kDouble, formatDouble(v), formatDouble(v), unit, help};
}
void Params::add(const std::string& name, int v, const std::string& unit, const std::string& help) {
  order_.push_back(name);
  entries_[name] = {Type::kInt, std::to_string(v), std::to_string(v), unit, help};
}
void Params::add(const std::string& name, bool v, const std::string& help) {
  order_.push_back(name);
  entries_[name] = {Type::kBool, v ? "true" : "false", v ? "true" : "false", "", help};
}
void Params::add(const std::string& name, const char* v, const std::string& help) {
  order_.push_back(name);
  entries_[name] = {Type::kString, v, v, "", help};
}
void Params::addSection(const std::string& name, const std::string& help) {
  if (!hasSection(name)) sections_.emplace_back(name, help);
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
  e.value = v;
}

void Params::set(const std::string& name, const std::string& value) {
  setFrom(name, value, "set");
}

void Params::parseConfigFile(const std::string& path) {
  config_path_ = path;
  config_ = openForRead(path, "config file");
  const std::string where = "config file '" + path + "'";
  cv::FileNode root = config_.root();
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
    if (normalise(name) == "config") parseConfigFile(value);
  }
  for (const auto& [name, value] : flags) {
    if (normalise(name) != "config") setFrom(name, value, "flag --" + name);
  }
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
    if (!e.default_value.empty()) s << " (default " << e.default_value << ")";
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
  s << "| parameter | unit | default | meaning |\n|---|---|---|---|\n";
  // A '|' inside a cell would end it.
  auto cell = [](const std::string& text) {
    std::string out;
    for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  for (const auto& name : order_) {
    const Entry& e = entries_.at(name);
    s << "| `" << name << "` | " << e.unit << " | " << cell(e.default_value) << " | "
      << cell(e.help) << " |\n";
  }
  for (const auto& [name, help] : sections_) {
    s << "| `" << name << ":` (section) |  |  | " << cell(help) << " |\n";
  }
  return s.str();
}

}  // namespace ptz
