// Text inside the XML files the pipeline writes by hand (.feb, .pvtu, .pvd): attribute values escaped,
// and comments that stay well-formed XML whatever they quote.
#pragma once

#include <string>

namespace vim::pipeline {

// `s` with & < > " replaced by their entities, for an attribute value or element text.
std::string xml_escape(const std::string& s);

// "<!-- text -->" for any text: XML forbids "--" inside a comment (and a comment ending in "-"), so
// every "--" becomes "- -" and a trailing '-' is followed by a space.
std::string xml_comment(const std::string& text);

}  // namespace vim::pipeline
