// The one error type of scene and image input: a message that already names
// the file, the place and the problem, printed as one line by the CLI.
#pragma once

#include <stdexcept>
#include <string>

namespace luz {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
  InputError(const std::string& file, int line, const std::string& problem)
      : std::runtime_error(line > 0 ? file + ":" + std::to_string(line) + ": " + problem : file + ": " + problem) {}
};

}  // namespace luz
