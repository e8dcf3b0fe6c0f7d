// SOAP bytes read with libxml2 (a well-kept parser, in Debian, that both the ONVIF client and
// ptz-sim's ONVIF server use): the size is checked before parsing, and the parser never loads a
// DTD, expands an entity or touches the network. Elements are found by local name, so a camera's
// choice of namespace prefixes does not matter.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct _xmlDoc;
struct _xmlNode;

namespace ptz::onvif {

// No ONVIF reply this project reads is near this; a larger one is refused unparsed.
constexpr std::size_t kMaxXmlBytes = 512 * 1024;
// Deeper nesting than any SOAP message has is refused too (libxml2 itself allows 256).
constexpr int kMaxXmlDepth = 64;

// A non-owning view of one element; invalid (valid() false) where nothing was found, and every
// lookup on an invalid node gives an invalid node, so paths need no check at each step.
class XmlNode {
 public:
  XmlNode() = default;
  explicit XmlNode(_xmlNode* node) : node_(node) {}

  bool valid() const { return node_ != nullptr; }
  std::string_view localName() const;
  std::string_view namespaceUri() const;
  // The first element child with this local name.
  XmlNode child(std::string_view local_name) const;
  // Every element child with this local name ("" for all element children).
  std::vector<XmlNode> children(std::string_view local_name = "") const;
  // Descends by local names: find({"Body", "GetStatusResponse", "PTZStatus"}).
  XmlNode find(std::initializer_list<std::string_view> path) const;
  // The first element anywhere below (depth first) with this local name.
  XmlNode descendant(std::string_view local_name) const;
  // The text content, leading and trailing white space removed.
  std::string text() const;
  std::optional<std::string> attribute(std::string_view local_name) const;

 private:
  _xmlNode* node_ = nullptr;
};

class XmlDocument {
 public:
  // Parses bytes; ok() false and error() saying why (too large, not well formed, too deep).
  static XmlDocument parse(std::string_view bytes);

  bool ok() const { return doc_ != nullptr; }
  const std::string& error() const { return error_; }
  XmlNode root() const;

 private:
  struct Free {
    void operator()(_xmlDoc* doc) const;
  };
  std::unique_ptr<_xmlDoc, Free> doc_;
  std::string error_;
};

// Text escaped for an element's content or an attribute's value.
std::string xmlEscape(std::string_view text);

}  // namespace ptz::onvif
