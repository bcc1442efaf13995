#include "luz/io/pbrt/tokenizer.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "luz/io/error.h"

namespace luz::pbrt {

Tokenizer::Tokenizer(std::string file, std::string text) : file_(std::move(file)), text_(std::move(text)) {}

Tokenizer Tokenizer::from_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open file: ") + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path, 0, "cannot read file");
  return Tokenizer(path, ss.str());
}

bool Tokenizer::next(Token& t) {
  const size_t n = text_.size();
  for (;;) {
    if (pos_ >= n) return false;
    const char c = text_[pos_];
    if (c == '\n') {
      ++line_, ++pos_;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++pos_;
    } else if (c == '#') {
      while (pos_ < n && text_[pos_] != '\n') ++pos_;
    } else {
      break;
    }
  }
  const size_t start = pos_;
  t.line = line_;
  const char c = text_[pos_];
  if (c == '"') {
    ++pos_;
    for (;;) {
      if (pos_ >= n) throw InputError(file_, t.line, "unterminated string");
      const char d = text_[pos_];
      if (d == '\n') throw InputError(file_, t.line, "line break inside a string (unterminated string?)");
      ++pos_;
      if (d == '\\') {
        if (pos_ >= n) throw InputError(file_, t.line, "unterminated string");
        if (text_[pos_] == '\n') throw InputError(file_, t.line, "line break inside a string (unterminated string?)");
        ++pos_;
      } else if (d == '"') {
        break;
      }
    }
  } else if (c == '[' || c == ']') {
    ++pos_;
  } else {
    while (pos_ < n) {
      const char d = text_[pos_];
      if (d == ' ' || d == '\n' || d == '\t' || d == '\r' || d == '\f' || d == '\v' || d == '"' || d == '[' ||
          d == ']' || d == '#')
        break;
      ++pos_;
    }
  }
  t.text = std::string_view(text_).substr(start, pos_ - start);
  return true;
}

std::string unquote(const std::string& file, const Token& t) {
  std::string out;
  const std::string_view s = t.text.substr(1, t.text.size() - 2);
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '\\') {
      out += s[i];
      continue;
    }
    switch (s[++i]) {
      case 'b': out += '\b'; break;
      case 'f': out += '\f'; break;
      case 'n': out += '\n'; break;
      case 'r': out += '\r'; break;
      case 't': out += '\t'; break;
      case '\\': out += '\\'; break;
      case '\'': out += '\''; break;
      case '"': out += '"'; break;
      default: throw InputError(file, t.line, std::string("unknown escape '\\") + s[i] + "' in a string");
    }
  }
  return out;
}

}  // namespace luz::pbrt
