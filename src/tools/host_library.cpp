#include "host_library.h"

#include <dlfcn.h>

#include <cstring>

namespace cadinterp::tools {

HostLibrary::~HostLibrary() {
  if (library_) dlclose(library_);
}

const cadinterp_host* HostLibrary::load(const std::string& path, const std::string& model,
                                        const std::string& options) {
  if (library_) throw std::logic_error("HostLibrary::load called twice");
  library_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!library_) {
    const char* e = dlerror();
    throw HostLoadError(CADINTERP_E_IO,
                        "cannot load host library " + path + ": " + (e ? e : "unknown error"));
  }
  void* sym = dlsym(library_, CADINTERP_HOST_ENTRY_NAME);
  if (!sym)
    throw HostLoadError(
        CADINTERP_E_INVALID_ARGUMENT,
        path + " exports no " CADINTERP_HOST_ENTRY_NAME " function (see cadinterp_host_entry_fn)");
  cadinterp_host_entry_fn entry = nullptr;
  // POSIX: a function pointer obtained from dlsym is usable as such.
  std::memcpy(&entry, &sym, sizeof entry);
  host_ = host_from_entry(entry, path, model, options);
  return host_;
}

const cadinterp_host* host_from_entry(cadinterp_host_entry_fn entry, const std::string& source,
                                      const std::string& model, const std::string& options) {
  const char* error = nullptr;
  const cadinterp_host* h = entry(model.empty() ? nullptr : model.c_str(),
                                  options.empty() ? nullptr : options.c_str(), &error);
  if (!h)
    throw HostLoadError(CADINTERP_E_INVALID_ARGUMENT, "the host (" + source + ") refused model '" +
                                                          model + "' with options '" + options +
                                                          "': " + (error ? error : "no message"));
  return h;
}

bool looks_like_library_path(const std::string& spec) {
  return spec.find('/') != std::string::npos || spec.find(".so") != std::string::npos;
}

}  // namespace cadinterp::tools
