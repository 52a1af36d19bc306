// A read-only memory mapping of a whole file: the one place where the asset reader meets the
// operating system (mapped_file_posix.cpp: mmap; mapped_file_win32.cpp: file mapping objects).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace cadinterp::format {

/// The bytes of one regular file, mapped read-only for the object's lifetime. Not copyable or
/// movable. Thread-safe for concurrent reads of data() and will_need() calls.
class MappedFile {
 public:
  /// Maps the regular file at `path` (UTF-8 on every platform). An empty file maps to
  /// data() == nullptr, size() == 0. Never blocks on a FIFO or a device.
  /// @throws FormatError with Status::Io, naming the path and the system's reason, when the file
  ///         cannot be opened, is not a regular file (a directory, FIFO or device), or cannot be
  ///         mapped; Status::InvalidArgument when `path` is not valid UTF-8 (Windows).
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const std::uint8_t* data() const { return data_; }
  std::uint64_t size() const { return size_; }

  /// Hints that [p, p + n), inside the mapping, is read soon: the pages are read in one request
  /// instead of one fault at a time. Has no effect where the system has no such hint.
  void will_need(const void* p, std::size_t n) const;

 private:
  const std::uint8_t* data_ = nullptr;
  std::uint64_t size_ = 0;
};

}  // namespace cadinterp::format
