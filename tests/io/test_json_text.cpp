#include "io/json_text.hpp"

#include <gtest/gtest.h>

#include <string>

using f16race::io::json_string;

TEST(JsonText, PlainTextIsQuotedOnly) {
  EXPECT_EQ(json_string("configs/default.yaml"), "\"configs/default.yaml\"");
  EXPECT_EQ(json_string(""), "\"\"");
  // UTF-8 passes through byte for byte (JSON text is UTF-8).
  EXPECT_EQ(json_string("Gr\xC3\xBC\xC3\x9F"), "\"Gr\xC3\xBC\xC3\x9F\"");
}

TEST(JsonText, QuotesBackslashesAndControlCharactersAreEscaped) {
  EXPECT_EQ(json_string("a\"b"), "\"a\\\"b\"");
  EXPECT_EQ(json_string("C:\\runs\\x"), "\"C:\\\\runs\\\\x\"");
  EXPECT_EQ(json_string("tab\there\nnew\rret"), "\"tab\\there\\nnew\\rret\"");
  EXPECT_EQ(json_string(std::string("\b\f", 2)), "\"\\b\\f\"");
  EXPECT_EQ(json_string(std::string("\x01\x1f", 2)), "\"\\u0001\\u001f\"");
  EXPECT_EQ(json_string(std::string("a\0b", 3)), "\"a\\u0000b\"");
}

TEST(JsonText, NoRawControlCharacterOrLoneQuoteSurvives) {
  // Every byte below 0x20 and both specials, one string: the literal holds no raw control
  // character, and every inner quote follows a backslash.
  std::string all;
  for (int c = 0; c < 0x20; ++c) all += static_cast<char>(c);
  all += "\"\\";
  const std::string j = json_string(all);
  ASSERT_GE(j.size(), 2u);
  EXPECT_EQ(j.front(), '"');
  EXPECT_EQ(j.back(), '"');
  bool escaped = false;
  for (std::size_t i = 1; i + 1 < j.size(); ++i) {
    EXPECT_GE(static_cast<unsigned char>(j[i]), 0x20u) << "raw control byte at " << i;
    if (!escaped && j[i] == '"') ADD_FAILURE() << "unescaped quote at " << i;
    escaped = !escaped && j[i] == '\\';
  }
  EXPECT_FALSE(escaped) << "the literal ends inside an escape";
}
