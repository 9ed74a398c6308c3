// What a managed process (or a state's command) prints: a bounded ring of
// its last lines, numbered so that a reader can ask for what is new, and an
// optional log file that is rotated at a size limit (.1, .2, ... kept).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace ln::manager {

class OutputRing {
 public:
  /// Lines longer than this are split, so that output without newlines
  /// cannot make the ring grow without bound.
  static constexpr std::size_t max_line = 16 * 1024;

  explicit OutputRing(std::size_t max_lines) : max_lines_(max_lines == 0 ? 1 : max_lines) {}

  /// Appends output as it arrived; `on_line` sees every line completed by
  /// it (without "\r\n").
  void append(std::string_view bytes, const std::function<void(const std::string&)>& on_line);
  /// Completes a partial last line (at the end of the output).
  void flush(const std::function<void(const std::string&)>& on_line);
  /// The incomplete last line so far (a prompt, for instance).
  const std::string& partial() const { return partial_; }

  struct Slice {
    std::vector<std::string> lines;
    std::uint64_t first = 0;    ///< number of lines[0]; the next line is last + 1
    std::uint64_t last = 0;     ///< number of the newest line (0: none yet)
    std::uint64_t dropped = 0;  ///< lines after `after` that the ring no longer holds
  };
  /// Lines numbered after `after` (at most `max`, the oldest first).
  Slice since(std::uint64_t after, std::size_t max) const;
  /// The last `count` lines.
  Slice tail(std::size_t count) const;

  std::uint64_t last_number() const { return next_ - 1; }
  void set_max_lines(std::size_t max_lines) { max_lines_ = max_lines == 0 ? 1 : max_lines; }

 private:
  void push(std::string line, const std::function<void(const std::string&)>& on_line);

  std::size_t max_lines_;
  std::deque<std::string> lines_;
  std::uint64_t next_ = 1;  ///< number of the next line
  std::string partial_;
};

/// An output log file, rotated when it reaches `size_limit`: the file
/// becomes FILE.1, FILE.1 becomes FILE.2, ... up to `keep` old files.
class OutputLog {
 public:
  OutputLog(std::string path, std::uint64_t size_limit, unsigned keep);
  ~OutputLog();
  OutputLog(const OutputLog&) = delete;
  OutputLog& operator=(const OutputLog&) = delete;

  /// Appends one line. Returns the reason when the file cannot be written
  /// ("" otherwise); it is retried at the next line.
  std::string write_line(const std::string& line);

 private:
  std::string open_file();
  void rotate();

  std::string path_;
  std::uint64_t size_limit_;
  unsigned keep_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

}  // namespace ln::manager
