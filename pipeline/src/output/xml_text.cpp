// XML text (xml_text.hpp): escaped attribute values and well-formed comments.
#include "output/xml_text.hpp"

namespace vim::pipeline {

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&':
        r += "&amp;";
        break;
      case '<':
        r += "&lt;";
        break;
      case '>':
        r += "&gt;";
        break;
      case '"':
        r += "&quot;";
        break;
      default:
        r += c;
    }
  }
  return r;
}

std::string xml_comment(const std::string& text) {
  std::string body;
  for (char c : text) {
    if (c == '-' && !body.empty() && body.back() == '-') body += ' ';
    body += c;
  }
  if (!body.empty() && body.back() == '-') body += ' ';
  return "<!-- " + body + " -->";
}

}  // namespace vim::pipeline
