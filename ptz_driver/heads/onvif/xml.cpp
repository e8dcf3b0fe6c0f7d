#include "ptz_driver/heads/onvif/xml.hpp"

#include <libxml/parser.h>
#include <libxml/tree.h>

#include <cstring>
#include <mutex>

namespace ptz::onvif {
namespace {

bool isElement(const xmlNode* node) {
  return node->type == XML_ELEMENT_NODE;
}

std::string_view view(const xmlChar* s) {
  return s ? std::string_view(reinterpret_cast<const char*>(s)) : std::string_view();
}

int depthBelow(const xmlNode* node, int depth) {
  if (depth > kMaxXmlDepth) return depth;
  int deepest = depth;
  for (const xmlNode* c = node->children; c; c = c->next) {
    if (isElement(c)) deepest = std::max(deepest, depthBelow(c, depth + 1));
    if (deepest > kMaxXmlDepth) break;
  }
  return deepest;
}

// libxml2 prints parse errors to stderr by default: a hostile peer must not fill our log.
void silent(void*, const char*, ...) {}

}  // namespace

std::string_view XmlNode::localName() const {
  return node_ ? view(node_->name) : "";
}

std::string_view XmlNode::namespaceUri() const {
  return node_ && node_->ns ? view(node_->ns->href) : "";
}

XmlNode XmlNode::child(std::string_view local_name) const {
  if (!node_) return {};
  for (xmlNode* c = node_->children; c; c = c->next) {
    if (isElement(c) && view(c->name) == local_name) return XmlNode(c);
  }
  return {};
}

std::vector<XmlNode> XmlNode::children(std::string_view local_name) const {
  std::vector<XmlNode> found;
  if (!node_) return found;
  for (xmlNode* c = node_->children; c; c = c->next) {
    if (isElement(c) && (local_name.empty() || view(c->name) == local_name)) {
      found.emplace_back(c);
    }
  }
  return found;
}

XmlNode XmlNode::find(std::initializer_list<std::string_view> path) const {
  XmlNode at = *this;
  for (std::string_view name : path) at = at.child(name);
  return at;
}

XmlNode XmlNode::descendant(std::string_view local_name) const {
  if (!node_) return {};
  for (xmlNode* c = node_->children; c; c = c->next) {
    if (!isElement(c)) continue;
    if (view(c->name) == local_name) return XmlNode(c);
    if (XmlNode below = XmlNode(c).descendant(local_name); below.valid()) return below;
  }
  return {};
}

std::string XmlNode::text() const {
  if (!node_) return "";
  xmlChar* content = xmlNodeGetContent(node_);
  std::string s(view(content));
  xmlFree(content);
  const char* space = " \t\r\n";
  const auto first = s.find_first_not_of(space);
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(space) - first + 1);
}

std::optional<std::string> XmlNode::attribute(std::string_view local_name) const {
  if (!node_) return std::nullopt;
  for (xmlAttr* a = node_->properties; a; a = a->next) {
    if (view(a->name) != local_name) continue;
    xmlChar* value = xmlNodeListGetString(node_->doc, a->children, 1);
    std::string s(view(value));
    xmlFree(value);
    return s;
  }
  return std::nullopt;
}

void XmlDocument::Free::operator()(_xmlDoc* doc) const {
  xmlFreeDoc(doc);
}

XmlDocument XmlDocument::parse(std::string_view bytes) {
  static std::once_flag init;
  std::call_once(init, [] {
    xmlInitParser();
    xmlSetGenericErrorFunc(nullptr, silent);
  });
  XmlDocument result;
  if (bytes.size() > kMaxXmlBytes) {
    result.error_ = "reply of " + std::to_string(bytes.size()) + " bytes is over the limit of " +
                    std::to_string(kMaxXmlBytes);
    return result;
  }
  // No DTD loading, no entity substitution, no network; errors not printed.
  const int options =
      XML_PARSE_NONET | XML_PARSE_NOERROR | XML_PARSE_NOWARNING | XML_PARSE_NOBLANKS;
  xmlDoc* doc =
      xmlReadMemory(bytes.data(), static_cast<int>(bytes.size()), "reply.xml", nullptr, options);
  if (!doc) {
    const xmlError* e = xmlGetLastError();
    result.error_ = std::string("not well-formed XML") +
                    (e && e->message ? ": " + std::string(e->message) : std::string());
    while (!result.error_.empty() && result.error_.back() == '\n') result.error_.pop_back();
    return result;
  }
  result.doc_.reset(doc);
  if (doc->intSubset || doc->extSubset) {
    result.doc_.reset();
    result.error_ = "a DTD in a SOAP message (refused)";
    return result;
  }
  const xmlNode* root = xmlDocGetRootElement(doc);
  if (!root) {
    result.doc_.reset();
    result.error_ = "no root element";
  } else if (depthBelow(root, 1) > kMaxXmlDepth) {
    result.doc_.reset();
    result.error_ = "elements nested deeper than " + std::to_string(kMaxXmlDepth);
  }
  return result;
}

XmlNode XmlDocument::root() const {
  return doc_ ? XmlNode(xmlDocGetRootElement(doc_.get())) : XmlNode();
}

std::string xmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace ptz::onvif
