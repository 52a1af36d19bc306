/* cadinterp library and ABI versions (CONVENTIONS.md: library, ABI and asset format versions are
 * kept apart; the asset format's is the runtime's cadinterp_format_version). C99-clean. */
#ifndef CADINTERP_VERSION_H
#define CADINTERP_VERSION_H

#define CADINTERP_VERSION_MAJOR 0
#define CADINTERP_VERSION_MINOR 1
#define CADINTERP_VERSION_PATCH 0
/** MAJOR * 10000 + MINOR * 100 + PATCH, for compile-time comparisons. */
#define CADINTERP_VERSION_NUMBER \
  (CADINTERP_VERSION_MAJOR * 10000 + CADINTERP_VERSION_MINOR * 100 + CADINTERP_VERSION_PATCH)

/** ABI version: N in the SONAMEs libcadinterp.so.N and libcadinterp_builder.so.N (the build
 * takes SOVERSION from here). It changes when a released declaration changes incompatibly. While
 * it is 0 (library 0.x) a release may change the ABI; CHANGELOG.md lists each change. */
#define CADINTERP_ABI_VERSION 0

#endif /* CADINTERP_VERSION_H */
