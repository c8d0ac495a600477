// Errors raised by the mosyn library. The library never prints or exits; the CLI's main()
// turns these into messages and exit codes (1 for Error, 2 for usage errors).
#pragma once

#include <stdexcept>
#include <string>

namespace mosyn {

// Any runtime or input error: a bad file, an inconsistent dataset, a missing model.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A request whose options are invalid or contradict each other (a flag out of range, an unknown
// label, two control sources at once): the caller's mistake, found when a job validates its
// options before running. The CLI exits with 2 for these, as for a malformed command line.
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

// An error at a place in an input file. what() reads "file:line: message"
// (or "file: message" when line is 0, i.e. the error concerns the whole file).
class ParseError : public Error {
 public:
  ParseError(std::string file, int line, const std::string& message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }

 private:
  std::string file_;
  int line_;
};

}  // namespace mosyn
