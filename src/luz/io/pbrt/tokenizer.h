// pbrt-v4 scene files, first stage: the tokens of one file (pbrt-v4's
// parser.cpp Tokenizer). A token is a word or number, a quoted string (kept
// with its quotes; unquote() resolves the escapes), or a bracket; `#` starts
// a comment to the end of the line. Every token carries its line.
#pragma once

#include <string>
#include <string_view>

namespace luz::pbrt {

struct Token {
  std::string_view text;  // a view into the Tokenizer's text
  int line = 0;
  bool quoted() const { return !text.empty() && text.front() == '"'; }
  bool is(std::string_view s) const { return text == s; }
};

class Tokenizer {
 public:
  // `file`: the name messages give; `text`: its contents.
  Tokenizer(std::string file, std::string text);
  // Reads `path` whole (InputError "path: cannot open ..." when it cannot).
  static Tokenizer from_file(const std::string& path);

  // The next token, or false at the end of the text. Throws InputError
  // "file:line: ..." on an unterminated string or a line break inside one.
  bool next(Token& t);
  const std::string& file() const { return file_; }

 private:
  std::string file_, text_;
  size_t pos_ = 0;
  int line_ = 1;
};

// The contents of a quoted token, its escapes (\b \f \n \r \t \\ \' \") resolved.
// Throws InputError on an unknown escape.
std::string unquote(const std::string& file, const Token& t);

}  // namespace luz::pbrt
