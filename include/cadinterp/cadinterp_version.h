/* cadinterp library and ABI versions (CONVENTIONS.md: library, ABI and asset format versions are
 * kept apart; the asset format's is the runtime's cadinterp_format_version), and the mark of a
 * deprecated name. C99-clean; cadinterp.h and cadinterp_builder.h both include it. */
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

/** Marks a declaration kept for one release under an old name (CHANGELOG.md, "Deprecated");
 * compilers warn where it is used, in C99 and C++ alike. Define CADINTERP_DEPRECATED(msg) as
 * empty before including any cadinterp header to silence them. */
#ifndef CADINTERP_DEPRECATED
#if defined(_MSC_VER)
#define CADINTERP_DEPRECATED(msg) __declspec(deprecated(msg))
#elif defined(__GNUC__) || defined(__clang__)
#define CADINTERP_DEPRECATED(msg) __attribute__((deprecated(msg)))
#else
#define CADINTERP_DEPRECATED(msg)
#endif
#endif

#endif /* CADINTERP_VERSION_H */
