// The one mapping from a C++ exception to a C ABI status and message, for every exported
// function of the project's C ABIs (libcadinterp, libcadinterp_builder) and for the host
// adapter's calls into a host's callbacks (after Embree's RTC_CATCH_BEGIN / RTC_CATCH_END):
// nothing thrown crosses a C interface (include/cadinterp/cadinterp.h, "Conventions").
// Header-only; it knows the format module's FormatError and the standard exceptions, and a C
// ABI maps its own exception types first (CADINTERP_CATCH_END_MAP).
//
//   cadinterp_status cadinterp_something(cadinterp_workspace* ws, ...) {
//     if (!ws) return CADINTERP_E_INVALID_ARGUMENT;
//     CADINTERP_CATCH_BEGIN
//     return do_something(ws, ...);
//     CADINTERP_CATCH_END(&ws->error)
//   }
#pragma once

#include <exception>
#include <new>
#include <string>

#include "cadinterp/cadinterp_status.h"
#include "format/asset_format.h"

namespace cadinterp::capi {

// A C ABI's own exception types: rethrows the exception being handled (`throw;`), and for a type
// it knows sets *status and, if error is non-null, *error, and returns true; false otherwise.
using ExceptionMap = bool (*)(cadinterp_status* status, std::string* error);

// The status of the exception being handled, its message stored in *error when error is
// non-null. Call only inside a catch block. `map` (may be null) sees the exception first; then
// format::FormatError -> its status and what(); std::bad_alloc -> CADINTERP_E_OUT_OF_MEMORY;
// any other exception -> CADINTERP_E_INTERNAL with "internal error: " and what() if it has one.
// If storing the message itself runs out of memory, the status is CADINTERP_E_OUT_OF_MEMORY and
// the message "out of memory" (short enough for std::string's inline buffer: no allocation).
inline cadinterp_status current_exception_status(std::string* error,
                                                 ExceptionMap map = nullptr) noexcept {
  cadinterp_status status = CADINTERP_E_INTERNAL;
  try {
    try {
      if (map && map(&status, error)) return status;
      throw;
    } catch (const format::FormatError& e) {
      status = static_cast<cadinterp_status>(static_cast<int>(e.status));
      if (error) *error = e.what();
    } catch (const std::bad_alloc&) {
      status = CADINTERP_E_OUT_OF_MEMORY;
      if (error) *error = "out of memory";
    } catch (const std::exception& e) {
      status = CADINTERP_E_INTERNAL;
      if (error) *error = std::string("internal error: ") + e.what();
    } catch (...) {
      status = CADINTERP_E_INTERNAL;
      if (error) *error = "internal error: unknown exception";
    }
  } catch (...) {
    status = CADINTERP_E_OUT_OF_MEMORY;
    if (error) *error = "out of memory";
  }
  return status;
}

}  // namespace cadinterp::capi

// Opens the guarded body of an exported function; the body returns a cadinterp_status.
#define CADINTERP_CATCH_BEGIN try {
// Closes it: an exception becomes the function's returned status, its message stored in the
// std::string `error` points to (nullptr: none kept).
#define CADINTERP_CATCH_END(error)                               \
  }                                                              \
  catch (...) {                                                  \
    return ::cadinterp::capi::current_exception_status((error)); \
  }
// As CADINTERP_CATCH_END, with a C ABI's own exception types mapped first (capi::ExceptionMap).
#define CADINTERP_CATCH_END_MAP(error, map)                             \
  }                                                                     \
  catch (...) {                                                         \
    return ::cadinterp::capi::current_exception_status((error), (map)); \
  }
