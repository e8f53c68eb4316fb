#include "pg_control/user_text.h"

namespace pg_control {
namespace {

constexpr char kEllipsis[] = "\xE2\x80\xA6";  // U+2026 in UTF-8, whatever the compiler's execution character set

bool isContinuation(char byte) { return (static_cast<unsigned char>(byte) & 0xC0U) == 0x80U; }

}  // namespace

std::size_t countChars(const std::string& text) {
  std::size_t chars = 0;
  for (const char byte : text) {
    if (!isContinuation(byte)) ++chars;
  }
  return chars;
}

std::string cutUserText(const std::string& text, std::size_t max_chars) {
  const std::size_t chars = countChars(text);
  if (chars <= max_chars) return text;
  std::size_t end = 0;  // byte index of the first character not kept
  for (std::size_t kept = 0; end < text.size(); ++end) {
    if (isContinuation(text[end])) continue;
    if (kept == max_chars) break;
    ++kept;
  }
  return text.substr(0, end) + kEllipsis + "(" + std::to_string(chars) + " chars)";
}

std::string cutUserTextIn(const std::string& message, const std::string& user_text, std::size_t max_chars) {
  const std::string cut = cutUserText(user_text, max_chars);
  if (user_text.empty() || cut == user_text) return message;
  std::string out;
  std::size_t from = 0;
  for (std::size_t at = message.find(user_text); at != std::string::npos; at = message.find(user_text, from)) {
    out.append(message, from, at - from).append(cut);
    from = at + user_text.size();
  }
  return out.append(message, from, std::string::npos);
}

}  // namespace pg_control
