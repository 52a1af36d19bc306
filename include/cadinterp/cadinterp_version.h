/* cadinterp library version (CONVENTIONS.md: library, ABI and asset format versions are kept
 * apart; this header holds the library's). C99-clean. */
#ifndef CADINTERP_VERSION_H
#define CADINTERP_VERSION_H

#define CADINTERP_VERSION_MAJOR 0
#define CADINTERP_VERSION_MINOR 1
#define CADINTERP_VERSION_PATCH 0
/** MAJOR * 10000 + MINOR * 100 + PATCH, for compile-time comparisons. */
#define CADINTERP_VERSION_NUMBER \
  (CADINTERP_VERSION_MAJOR * 10000 + CADINTERP_VERSION_MINOR * 100 + CADINTERP_VERSION_PATCH)

#endif /* CADINTERP_VERSION_H */
