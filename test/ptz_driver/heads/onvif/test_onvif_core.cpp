// ptz_onvif_core: the libxml2 reader's limits and lookups, the WS-Security digest (the ONVIF
// Application Programmer's Guide's vector, and the openssl command line for random nonces),
// canonical Base64, xs:dateTime.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::onvif {
namespace {

TEST(OnvifWsSecurity, ProgrammersGuideVector) {
  const auto nonce = base64Decode("LKqI6G/AikKCQrN0zqZFlg==");
  ASSERT_TRUE(nonce);
  EXPECT_EQ(nonce->size(), 16u);
  EXPECT_EQ(passwordDigest(*nonce, "2010-09-16T07:50:45Z", "userpassword"),
            "tuOSpGlFlIXsozq4HFNeeGeFLEI=");
  EXPECT_NE(passwordDigest(*nonce, "2010-09-16T07:50:46Z", "userpassword"),
            "tuOSpGlFlIXsozq4HFNeeGeFLEI=");
}

// The command line's answer for SHA-1 + Base64 of a file's bytes.
std::string opensslDigest(const std::string& bytes) {
  const std::string path = testing::TempDir() + "onvif_digest_input.bin";
  std::ofstream(path, std::ios::binary) << bytes;
  const std::string command = "openssl dgst -sha1 -binary < '" + path + "' | base64";
  std::FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return "";
  std::string out;
  char buffer[128];
  while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
  pclose(pipe);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

TEST(OnvifWsSecurity, DigestAgreesWithOpensslCommandLine) {
  if (std::system("command -v openssl > /dev/null 2>&1") != 0) GTEST_SKIP() << "no openssl";
  std::mt19937 random(7);
  for (int i = 0; i < 8; ++i) {
    std::string nonce = i == 0 ? randomNonce() : std::string(16, '\0');
    if (i > 0) {
      for (char& c : nonce) c = static_cast<char>(random() & 0xFF);
    }
    const std::string created = xsDateTime(1.7e9 + i * 1234.5);
    const std::string password = "pw-" + std::to_string(random());
    EXPECT_EQ(passwordDigest(nonce, created, password), opensslDigest(nonce + created + password))
        << "nonce " << base64Encode(nonce);
  }
}

TEST(OnvifWsSecurity, Base64RoundTripsAndRefusesNonCanonical) {
  std::mt19937 random(3);
  for (std::size_t n = 0; n < 40; ++n) {
    std::string bytes(n, '\0');
    for (char& c : bytes) c = static_cast<char>(random() & 0xFF);
    const auto back = base64Decode(base64Encode(bytes));
    ASSERT_TRUE(back) << n;
    EXPECT_EQ(*back, bytes);
  }
  EXPECT_EQ(base64Decode("QQ==").value_or("x"), "A");
  for (const char* bad : {"QQ", "QR==", "QQ=A", "Q Q=", "QQ==QQ==", "Q===", "====", "QQ\n=", "Q"}) {
    EXPECT_FALSE(base64Decode(bad)) << bad;
  }
}

TEST(OnvifWsSecurity, UsernameTokenHeaderVerifies) {
  const UsernameToken token = makeUsernameToken("ad<min", "secret", 1284623445.0);
  EXPECT_EQ(token.created, "2010-09-16T07:50:45.000Z");
  EXPECT_EQ(token.digest, passwordDigest(token.nonce, token.created, "secret"));
  const std::string header = securityHeader(token);
  const XmlDocument doc =
      XmlDocument::parse("<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\">" +
                         header + "</s:Envelope>");
  ASSERT_TRUE(doc.ok()) << doc.error();
  const XmlNode ut = doc.root().find({"Security", "UsernameToken"});
  EXPECT_EQ(ut.child("Username").text(), "ad<min");
  EXPECT_EQ(base64Decode(ut.child("Nonce").text()).value_or(""), token.nonce);
  EXPECT_EQ(ut.child("Created").text(), token.created);
  EXPECT_EQ(ut.child("Password").text(), token.digest);
}

TEST(OnvifXsDateTime, RoundTripAndZones) {
  for (double t : {0.0, 1.5, 1284623445.0, 1700000000.125, 1999999999.999}) {
    const auto back = parseXsDateTime(xsDateTime(t));
    ASSERT_TRUE(back) << xsDateTime(t);
    EXPECT_NEAR(*back, t, 0.0006) << xsDateTime(t);
  }
  EXPECT_EQ(xsDateTime(1284623445.0), "2010-09-16T07:50:45.000Z");
  EXPECT_EQ(parseXsDateTime("2010-09-16T07:50:45Z").value_or(0), 1284623445.0);
  EXPECT_EQ(parseXsDateTime("2010-09-16T07:50:45").value_or(0), 1284623445.0);
  EXPECT_EQ(parseXsDateTime("2010-09-16T09:50:45+02:00").value_or(0), 1284623445.0);
  EXPECT_EQ(parseXsDateTime("2010-09-16T02:20:45-05:30").value_or(0), 1284623445.0);
  EXPECT_DOUBLE_EQ(parseXsDateTime("2010-09-16T07:50:45.25Z").value_or(0), 1284623445.25);
  for (const char* bad :
       {"", "2010-09-16", "2010-13-16T07:50:45Z", "2010-09-16T24:50:45Z",
        "2010-09-16T07:50:45+2:00", "2010-09-16T07:50:45ZZ", "2010-09-16T07:50:45.Z",
        "2010-09-16 07:50:45Z", "x010-09-16T07:50:45Z"}) {
    EXPECT_FALSE(parseXsDateTime(bad)) << bad;
  }
}

TEST(OnvifXml, FindsByLocalNameWhateverThePrefix) {
  const XmlDocument doc = XmlDocument::parse(
      "<a:Root xmlns:a=\"urn:a\" xmlns:b=\"urn:b\"><b:Item k=\"1\"> x &amp; y </b:Item>"
      "<b:Item k=\"2\"/><a:Other/></a:Root>");
  ASSERT_TRUE(doc.ok()) << doc.error();
  EXPECT_EQ(doc.root().localName(), "Root");
  EXPECT_EQ(doc.root().namespaceUri(), "urn:a");
  EXPECT_EQ(doc.root().children("Item").size(), 2u);
  EXPECT_EQ(doc.root().children().size(), 3u);
  EXPECT_EQ(doc.root().child("Item").text(), "x & y");
  EXPECT_EQ(doc.root().child("Item").namespaceUri(), "urn:b");
  EXPECT_EQ(doc.root().children("Item")[1].attribute("k").value_or(""), "2");
  EXPECT_FALSE(doc.root().find({"Item", "None", "Deeper"}).valid());
  EXPECT_FALSE(doc.root().child("Item").attribute("none"));
}

TEST(OnvifXml, RefusesDtdsDepthSizeAndBrokenXml) {
  const std::string laughs =
      "<?xml version=\"1.0\"?><!DOCTYPE lolz [<!ENTITY lol \"lol\">"
      "<!ENTITY lol2 \"&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;\">"
      "<!ENTITY lol3 \"&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;\">]>"
      "<lolz>&lol3;</lolz>";
  EXPECT_FALSE(XmlDocument::parse(laughs).ok());
  EXPECT_FALSE(XmlDocument::parse("<!DOCTYPE a SYSTEM \"file:///etc/passwd\"><a/>").ok());
  std::string deep;
  for (int i = 0; i < kMaxXmlDepth + 1; ++i) deep += "<a>";
  for (int i = 0; i < kMaxXmlDepth + 1; ++i) deep += "</a>";
  const XmlDocument too_deep = XmlDocument::parse(deep);
  EXPECT_FALSE(too_deep.ok());
  EXPECT_NE(too_deep.error().find("deeper"), std::string::npos) << too_deep.error();
  const XmlDocument too_large = XmlDocument::parse("<a>" + std::string(kMaxXmlBytes, 'x') + "</a>");
  EXPECT_FALSE(too_large.ok());
  EXPECT_NE(too_large.error().find("over the limit"), std::string::npos) << too_large.error();
  for (const char* bad : {"", "<a>", "<a></b>", "<a x=1/>", "\x01"}) {
    const XmlDocument doc = XmlDocument::parse(bad);
    EXPECT_FALSE(doc.ok()) << bad;
    EXPECT_FALSE(doc.error().empty());
  }
}

}  // namespace
}  // namespace ptz::onvif
