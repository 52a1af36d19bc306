// MappedFile on POSIX systems (Linux, macOS, Emscripten): open + fstat + mmap.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "format/asset_format.h"
#include "format/mapped_file.h"

namespace cadinterp::format {

MappedFile::MappedFile(const std::string& path) {
  // O_NONBLOCK: opening a FIFO without a writer (or a device) would otherwise wait forever; the
  // fstat below refuses anything but a regular file, for which the flag changes nothing.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) throw FormatError(Status::Io, "cannot open " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw FormatError(Status::Io, path + " is not a readable regular file");
  }
  size_ = static_cast<std::uint64_t>(st.st_size);
  if (size_ > 0) {
    void* m = mmap(nullptr, static_cast<std::size_t>(size_), PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      throw FormatError(Status::Io, "cannot map " + path + ": " + std::strerror(err));
    }
    // Open reads a few pages (header, index) and decoding reads one element's blobs: the
    // kernel's default read-ahead (8 MB on some disks) made the first fault of a cold open
    // cost ~4 ms. Blobs ask for their own pages (will_need).
    ::madvise(m, static_cast<std::size_t>(size_), MADV_RANDOM);
    data_ = static_cast<const std::uint8_t*>(m);
  }
  ::close(fd);
}

MappedFile::~MappedFile() {
  if (data_) munmap(const_cast<std::uint8_t*>(data_), static_cast<std::size_t>(size_));
}

void MappedFile::will_need(const void* p, std::size_t n) const {
  if (!data_ || n == 0) return;
  const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
  const std::uintptr_t first = reinterpret_cast<std::uintptr_t>(p) & ~(page - 1);
  ::madvise(reinterpret_cast<void*>(first), reinterpret_cast<std::uintptr_t>(p) + n - first,
            MADV_WILLNEED);
}

}  // namespace cadinterp::format
