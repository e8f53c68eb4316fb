// User-given text in the controller's answers and log lines, bounded: a frame or arm name from a request is repeated
// at most kEchoedChars characters long, so that a huge request never makes a huge answer. ROS-free.
#ifndef PG_CONTROL_USER_TEXT_H
#define PG_CONTROL_USER_TEXT_H

#include <cstddef>
#include <string>

namespace pg_control {

// Characters of a user-given string that a message repeats.
constexpr std::size_t kEchoedChars = 64;

// Characters of `text` as UTF-8 code points: every byte that is not a continuation byte (10xxxxxx) starts one.
std::size_t countChars(const std::string& text);

// `text` whole when it has at most `max_chars` characters (countChars); otherwise its first `max_chars` characters,
// an ellipsis and the original length: "ffff…(10000 chars)". The cut never splits a UTF-8 sequence, so valid UTF-8
// stays valid; the suffix adds at most 29 characters.
std::string cutUserText(const std::string& text, std::size_t max_chars = kEchoedChars);

// `message` (e.g. a library's error text) with every occurrence of `user_text` replaced by cutUserText(user_text,
// max_chars): the message keeps its wording and loses the huge quote. An empty `user_text` changes nothing.
std::string cutUserTextIn(const std::string& message, const std::string& user_text,
                          std::size_t max_chars = kEchoedChars);

}  // namespace pg_control

#endif  // PG_CONTROL_USER_TEXT_H
