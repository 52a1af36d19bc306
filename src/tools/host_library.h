// Loading a host shared library (`cadinterp build --host lib.so`, the mapping report, and every
// tool that runs a host in another process or rank): dlopen, look up the entry
// CADINTERP_HOST_ENTRY_NAME (cadinterp_host_entry_fn), and ask it for a model. One loader, so
// every tool gives the same messages for the same mistakes.
#pragma once

#include <stdexcept>
#include <string>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::tools {

/// Why a host library could not be used: `status` is CADINTERP_E_IO when the library cannot be
/// loaded, CADINTERP_E_INVALID_ARGUMENT when it has no entry or its entry refuses the model.
struct HostLoadError : std::runtime_error {
  HostLoadError(cadinterp_status s, const std::string& what)
      : std::runtime_error(what), status(s) {}
  cadinterp_status status;
};

/// A loaded host library. Owns the dlopen handle: the host it returned points into the library,
/// so it is valid while this object lives. Not copyable; not thread-safe (load it once, then
/// share `host`, whose own thread_safe flag says what the callbacks allow).
class HostLibrary {
 public:
  HostLibrary() = default;
  HostLibrary(const HostLibrary&) = delete;
  HostLibrary& operator=(const HostLibrary&) = delete;
  ~HostLibrary();

  /// Loads `path` (RTLD_NOW | RTLD_LOCAL) and returns its entry's host for `model` with `options`
  /// ("" for either: the library's defaults). Throws HostLoadError. At most once per object.
  const cadinterp_host* load(const std::string& path, const std::string& model,
                             const std::string& options);
  const cadinterp_host* host() const { return host_; }

 private:
  void* library_ = nullptr;
  const cadinterp_host* host_ = nullptr;
};

/// Asks `entry` for `model` with `options` ("" for either: defaults); `source` names the host in
/// the message. Throws HostLoadError (CADINTERP_E_INVALID_ARGUMENT) when the entry refuses.
const cadinterp_host* host_from_entry(cadinterp_host_entry_fn entry, const std::string& source,
                                      const std::string& model, const std::string& options);

/// True when a --host argument names a library file rather than a built-in host.
bool looks_like_library_path(const std::string& spec);

}  // namespace cadinterp::tools
