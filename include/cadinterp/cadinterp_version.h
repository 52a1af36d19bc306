/* cadinterp library and ABI versions (CONVENTIONS.md: library, ABI and asset format versions are
 * kept apart; the asset format's is the runtime's cadinterp_format_version), and the mark of a
 * deprecated name. C99-clean; cadinterp.h and cadinterp_builder.h both include it. */
#ifndef CADINTERP_VERSION_H
#define CADINTERP_VERSION_H

#define CADINTERP_VERSION_MAJOR 1
#define CADINTERP_VERSION_MINOR 0
#define CADINTERP_VERSION_PATCH 0
/** MAJOR * 10000 + MINOR * 100 + PATCH, for compile-time comparisons. */
#define CADINTERP_VERSION_NUMBER \
  (CADINTERP_VERSION_MAJOR * 10000 + CADINTERP_VERSION_MINOR * 100 + CADINTERP_VERSION_PATCH)

/** Runtime ABI version: N in the SONAME libcadinterp.so.N (the build takes SOVERSION from here).
 * ABI 1 is frozen (include/README.md, "Stability"): every 1.x release keeps each declaration of
 * cadinterp.h, cadinterp_status.h and this header, and grows only by addition (new functions,
 * appended status codes, options structs whose first member is their size). An incompatible
 * change would make it 2. abi/libcadinterp.abi is the baseline a test compares each build with. */
#define CADINTERP_ABI_VERSION 1

/** Builder ABI version: N in the SONAME libcadinterp_builder.so.N. 0 while the builder ABI
 * (cadinterp_builder.h) is experimental: a release may change it incompatibly, and CHANGELOG.md
 * lists each change. */
#define CADINTERP_BUILDER_ABI_VERSION 0

/** Optimizer ABI version: N in the SONAME libcadinterp_optimize.so.N. 0 while the optimizer ABI
 * (cadinterp_optimize.h) is experimental, in the builder's sense above. */
#define CADINTERP_OPTIMIZE_ABI_VERSION 0

/** Marks a declaration kept under an old name (CHANGELOG.md, "Deprecated");
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
