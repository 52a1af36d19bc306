/* cadinterp status codes: the one numbering shared by the runtime (cadinterp.h) and the builder
 * (cadinterp_builder.h); both headers include this one. C99-clean, declarations only (nothing to
 * link).
 *
 * Stability (the rule of zstd's zstd_errors.h, with stable values as well as names):
 * - Every value is explicit, and a released value never changes meaning or number. New codes are
 *   appended below the last one, so CADINTERP_STATUS_MAX_CODE grows.
 * - Every code lies in [0, CADINTERP_STATUS_MAX_CODE); CADINTERP_OK is 0 and every other code is a
 *   failure. A library newer than the header a program was compiled with may return a code at or
 *   above that program's CADINTERP_STATUS_MAX_CODE: treat it as a failure (cadinterp_status_string,
 *   in cadinterp.h, names the codes the linked runtime knows and says "unknown status" otherwise).
 * - The format module's internal codes (src/format/asset_format.h) equal codes 0..14 and are
 *   pinned to them by static_assert there.
 */
#ifndef CADINTERP_STATUS_H
#define CADINTERP_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

/** Status codes of every fallible runtime and builder function. */
typedef enum cadinterp_status {
  CADINTERP_OK = 0,
  CADINTERP_E_INVALID_ARGUMENT = 1, /**< NULL where a value is needed, index out of range... */
  CADINTERP_E_OUT_OF_MEMORY = 2,
  CADINTERP_E_IO = 3,                  /**< the file cannot be opened, mapped or read */
  CADINTERP_E_BAD_MAGIC = 4,           /**< not a cadinterp asset */
  CADINTERP_E_UNSUPPORTED_VERSION = 5, /**< other major, unknown required feature */
  CADINTERP_E_TRUNCATED = 6,           /**< the file is shorter than its header says */
  CADINTERP_E_CORRUPT_INDEX = 7,       /**< the index fails verification */
  CADINTERP_E_CHECKSUM = 8,            /**< stored bytes differ from their checksum */
  CADINTERP_E_OUT_OF_RANGE = 9,        /**< a blob lies outside the file (never a caller's index) */
  CADINTERP_E_LIMIT = 10,              /**< a count exceeds the reader's limits */
  CADINTERP_E_CORRUPT_BLOB = 11,       /**< mesh data fails to decode or holds invalid values */
  CADINTERP_E_OUTSIDE_DOMAIN = 12,     /**< x is outside the parameter box (or not finite) */
  CADINTERP_E_INFEASIBLE = 13,         /**< x lies where the model could not be built */
  CADINTERP_E_INTERNAL = 14,           /**< a bug: please report it with the message */
  CADINTERP_E_NOT_FOUND = 15,          /**< no field of that name */
  /* Returned by the builder only. */
  CADINTERP_E_CANCELLED = 16,      /**< the caller cancelled (builder progress callback) */
  CADINTERP_E_STORE_MISMATCH = 17, /**< a sample store written for another model/box */

  /** Not a status; grows: one more than the largest code above. Never returned; use it only to
   * size a table indexed by status or to test a code against the range this header knows. */
  CADINTERP_STATUS_MAX_CODE = 18
} cadinterp_status;

#ifdef __cplusplus
}
#endif

#endif /* CADINTERP_STATUS_H */
