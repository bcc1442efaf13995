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

  // Control characters (newlines above all) become spaces; trailing ones go.
  static std::string one_line(std::string s) {
    for (char& c : s)
      if (c == '\n' || c == '\r' || c == '\t' || c == '\v' || c == '\f') c = ' ';
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
