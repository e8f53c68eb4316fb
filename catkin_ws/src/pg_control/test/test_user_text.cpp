// Unit tests for the bounded echo of user-given text in the controller's messages (user_text.h; ROS-free).
#include <gtest/gtest.h>

#include <string>

#include "pg_control/user_text.h"

namespace pg_control {
namespace {

const std::string kEllipsis = "\xE2\x80\xA6";  // U+2026

TEST(CutUserText, ShortTextIsKeptWhole) {
  EXPECT_EQ(cutUserText(""), "");
  EXPECT_EQ(cutUserText("world"), "world");
  const std::string at_limit(kEchoedChars, 'f');
  EXPECT_EQ(cutUserText(at_limit), at_limit);
}

TEST(CutUserText, LongTextIsCutWithItsLength) {
  const std::string frame(10000, 'f');
  const std::string cut = cutUserText(frame);
  EXPECT_EQ(cut, std::string(kEchoedChars, 'f') + kEllipsis + "(10000 chars)");
  EXPECT_LT(cut.size(), 100U);
  EXPECT_EQ(cutUserText(std::string(kEchoedChars + 1, 'a')), std::string(kEchoedChars, 'a') + kEllipsis + "(65 chars)");
  EXPECT_EQ(cutUserText("abcdef", 3), "abc" + kEllipsis + "(6 chars)");
  EXPECT_EQ(cutUserText("abc", 0), kEllipsis + "(3 chars)");
}

TEST(CutUserText, CountsAndCutsWholeUtf8Characters) {
  const std::string oe = "\xC3\xB6";            // U+00F6, two bytes
  const std::string heart = "\xF0\x9F\x92\x9A";  // U+1F49A, four bytes
  EXPECT_EQ(countChars("w" + oe + "rld"), 5U);
  EXPECT_EQ(countChars(heart + heart), 2U);
  EXPECT_EQ(cutUserText(heart + heart + heart, 2), heart + heart + kEllipsis + "(3 chars)");
  std::string many;
  for (int i = 0; i < 100; ++i) many += oe;
  EXPECT_EQ(cutUserText(many), many.substr(0, 2 * kEchoedChars) + kEllipsis + "(100 chars)");
  EXPECT_EQ(cutUserText("w" + oe + "rld"), "w" + oe + "rld");  // 6 bytes, 5 characters: kept
  EXPECT_EQ(cutUserText("ab" + oe, 2), "ab" + kEllipsis + "(3 chars)");
}

TEST(CutUserTextIn, CutsEveryQuoteOfTheUserTextAndKeepsTheRest) {
  const std::string frame(10000, 'f');
  const std::string cut = std::string(kEchoedChars, 'f') + kEllipsis + "(10000 chars)";
  EXPECT_EQ(cutUserTextIn("\"" + frame + "\" passed to lookupTransform argument source_frame does not exist. ", frame),
            "\"" + cut + "\" passed to lookupTransform argument source_frame does not exist. ");
  EXPECT_EQ(cutUserTextIn(frame + " and " + frame, frame), cut + " and " + cut);
  EXPECT_EQ(cutUserTextIn("frame 'world' unknown", "world"), "frame 'world' unknown");  // short: unchanged
  EXPECT_EQ(cutUserTextIn("no frame", ""), "no frame");
  EXPECT_EQ(cutUserTextIn("abcdef abcdef", "abcdef", 3), "abc" + kEllipsis + "(6 chars) abc" + kEllipsis + "(6 chars)");
}

}  // namespace
}  // namespace pg_control

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
