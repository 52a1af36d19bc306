// MappedFile on Windows: CreateFileW + CreateFileMappingW + MapViewOfFile. Paths are UTF-8 (the
// C ABI's convention) and converted to UTF-16, so that any file name opens, not only those of
// the process's ANSI code page.
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#ifndef NOMINMAX
#define NOMINMAX
#endif
#include <windows.h>

#include <climits>
#include <string>

#include "format/asset_format.h"
#include "format/mapped_file.h"

namespace cadinterp::format {
namespace {

std::string system_message(DWORD code) {
  char buf[512];
  DWORD n = FormatMessageA(FORMAT_MESSAGE_FROM_SYSTEM | FORMAT_MESSAGE_IGNORE_INSERTS, nullptr,
                           code, 0, buf, sizeof buf, nullptr);
  while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r' || buf[n - 1] == '.')) --n;
  return n ? std::string(buf, n) : "Windows error " + std::to_string(code);
}

std::wstring widen(const std::string& utf8) {
  if (utf8.empty()) return {};
  if (utf8.size() > static_cast<std::size_t>(INT_MAX))
    throw FormatError(Status::InvalidArgument, "path too long");
  const int len = static_cast<int>(utf8.size());
  const int n = MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, utf8.data(), len, nullptr, 0);
  if (n <= 0) throw FormatError(Status::InvalidArgument, "path is not valid UTF-8: " + utf8);
  std::wstring w(static_cast<std::size_t>(n), L'\0');
  MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, utf8.data(), len, w.data(), n);
  return w;
}

// Closes a handle on every path out of the constructor.
struct Handle {
  HANDLE h;
  ~Handle() {
    if (h && h != INVALID_HANDLE_VALUE) CloseHandle(h);
  }
};

}  // namespace

MappedFile::MappedFile(const std::string& path) {
  // FILE_SHARE_DELETE: a mapped asset may be renamed or replaced while open, as on POSIX. A
  // directory cannot be opened without FILE_FLAG_BACKUP_SEMANTICS (ERROR_ACCESS_DENIED); a pipe
  // or device is refused by the type check below before anything is read.
  const Handle file{CreateFileW(widen(path).c_str(), GENERIC_READ,
                                FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, nullptr,
                                OPEN_EXISTING, FILE_ATTRIBUTE_NORMAL, nullptr)};
  if (file.h == INVALID_HANDLE_VALUE)
    throw FormatError(Status::Io, "cannot open " + path + ": " + system_message(GetLastError()));
  LARGE_INTEGER size{};
  if (GetFileType(file.h) != FILE_TYPE_DISK || !GetFileSizeEx(file.h, &size))
    throw FormatError(Status::Io, path + " is not a readable regular file");
  size_ = static_cast<std::uint64_t>(size.QuadPart);
  if (size_ == 0) return;  // CreateFileMapping refuses empty files
  const Handle mapping{CreateFileMappingW(file.h, nullptr, PAGE_READONLY, 0, 0, nullptr)};
  if (!mapping.h)
    throw FormatError(Status::Io, "cannot map " + path + ": " + system_message(GetLastError()));
  // The view keeps the mapping and the file open after both handles are closed.
  const void* view = MapViewOfFile(mapping.h, FILE_MAP_READ, 0, 0, 0);
  if (!view)
    throw FormatError(Status::Io, "cannot map " + path + ": " + system_message(GetLastError()));
  data_ = static_cast<const std::uint8_t*>(view);
}

MappedFile::~MappedFile() {
  if (data_) UnmapViewOfFile(data_);
}

// No hint: PrefetchVirtualMemory needs Windows 8 and the memory manager already reads a mapped
// view in clusters around each fault.
void MappedFile::will_need(const void*, std::size_t) const {}

}  // namespace cadinterp::format
