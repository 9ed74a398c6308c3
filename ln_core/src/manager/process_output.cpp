#include "manager/process_output.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace ln::manager {

void OutputRing::append(std::string_view bytes, const std::function<void(const std::string&)>& on_line) {
  while (!bytes.empty()) {
    const auto newline = bytes.find('\n');
    const std::size_t take = newline == std::string_view::npos ? bytes.size() : newline;
    const std::size_t room = max_line - partial_.size();
    if (take > room) {
      partial_.append(bytes.substr(0, room));
      bytes.remove_prefix(room);
      push(std::move(partial_), on_line);
      partial_.clear();
      continue;
    }
    partial_.append(bytes.substr(0, take));
    if (newline == std::string_view::npos) return;
    bytes.remove_prefix(take + 1);
    std::string line = std::move(partial_);
    partial_.clear();
    if (!line.empty() && line.back() == '\r') line.pop_back();
    push(std::move(line), on_line);
  }
}

void OutputRing::flush(const std::function<void(const std::string&)>& on_line) {
  if (partial_.empty()) return;
  std::string line = std::move(partial_);
  partial_.clear();
  if (!line.empty() && line.back() == '\r') line.pop_back();
  push(std::move(line), on_line);
}

void OutputRing::push(std::string line, const std::function<void(const std::string&)>& on_line) {
  if (on_line) on_line(line);
  lines_.push_back(std::move(line));
  ++next_;
  while (lines_.size() > max_lines_) lines_.pop_front();
}

OutputRing::Slice OutputRing::since(std::uint64_t after, std::size_t max) const {
  Slice slice;
  slice.last = next_ - 1;
  const std::uint64_t oldest = next_ - lines_.size();  // number of lines_.front()
  std::uint64_t from = after + 1;
  if (from < oldest) {
    slice.dropped = oldest - from;
    from = oldest;
  }
  slice.first = from;
  for (std::uint64_t n = from; n < next_ && slice.lines.size() < max; ++n)
    slice.lines.push_back(lines_[static_cast<std::size_t>(n - oldest)]);
  return slice;
}

OutputRing::Slice OutputRing::tail(std::size_t count) const {
  const std::uint64_t last = next_ - 1;
  return since(last > count ? last - count : 0, count);
}

OutputLog::OutputLog(std::string path, std::uint64_t size_limit, unsigned keep)
    : path_(std::move(path)), size_limit_(size_limit), keep_(keep) {}

OutputLog::~OutputLog() {
  if (fd_ >= 0) ::close(fd_);
}

std::string OutputLog::open_file() {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) return "cannot open the output log file '" + path_ + "': " + std::strerror(errno);
  struct stat st;
  size_ = ::fstat(fd_, &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  return "";
}

void OutputLog::rotate() {
  ::close(fd_);
  fd_ = -1;
  if (keep_ == 0) {
    ::unlink(path_.c_str());
    return;
  }
  for (unsigned n = keep_; n > 1; --n)
    ::rename((path_ + "." + std::to_string(n - 1)).c_str(), (path_ + "." + std::to_string(n)).c_str());
  ::rename(path_.c_str(), (path_ + ".1").c_str());
}

std::string OutputLog::write_line(const std::string& line) {
  if (fd_ < 0) {
    if (std::string problem = open_file(); !problem.empty()) return problem;
  }
  if (size_limit_ > 0 && size_ > 0 && size_ + line.size() + 1 > size_limit_) {
    rotate();
    if (std::string problem = open_file(); !problem.empty()) return problem;
  }
  std::string data = line + "\n";
  const char* p = data.data();
  std::size_t left = data.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return "cannot write the output log file '" + path_ + "': " + std::strerror(errno);
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  size_ += data.size();
  return "";
}

}  // namespace ln::manager
