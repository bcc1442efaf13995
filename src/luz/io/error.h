// The one error type of scene and image input: a message that already names
// the file, the place and the problem, printed as one line by the CLI.
// what() is "file:line: problem" ("file: problem" without a line, or just
// "problem" without a file). Line breaks in any part become spaces, so the
// message is always one line whatever a file name or a value contained.
#pragma once

#include <stdexcept>
#include <string>

namespace luz {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : InputError(std::string(), 0, what) {}
  InputError(const std::string& file, int line, const std::string& problem)
      : std::runtime_error(format(one_line(file), line, one_line(problem))),
        file_(one_line(file)),
        line_(line),
        problem_(one_line(problem)) {}

  const std::string& file() const { return file_; }  // empty when no file is involved
  int line() const { return line_; }                 // 0 when unknown or not applicable
  const std::string& problem() const { return problem_; }

  // Line breaks and tabs become spaces (trailing ones go); any other control
  // character is shown as \xNN, so that a byte the terminal would not show
  // (or would act on) is visible in the message.
  static std::string one_line(const std::string& in) {
    static const char* kHex = "0123456789abcdef";
    std::string s;
    for (char c : in) {
      unsigned char u = (unsigned char)c;
      if (c == '\n' || c == '\r' || c == '\t' || c == '\v' || c == '\f') s += ' ';
      else if (u < 0x20 || u == 0x7f) s += std::string("\\x") + kHex[u >> 4] + kHex[u & 15];
      else s += c;
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
  }

 private:
  static std::string format(const std::string& file, int line, const std::string& problem) {
    if (file.empty()) return problem;
    return line > 0 ? file + ":" + std::to_string(line) + ": " + problem : file + ": " + problem;
  }
  std::string file_;
  int line_ = 0;
  std::string problem_;
};

}  // namespace luz
