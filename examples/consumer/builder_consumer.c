/* cadinterp-builder-consumer: links the installed libcadinterp_builder through the CMake package
 * (cadinterp::builder) and checks that the library answers as its header says: the same release
 * as the header, and the documented defaults of cadinterp_build_options_init (struct_size, linear
 * degree). A build needs a host (examples/hosts); the runtime consumer (consumer.c) covers
 * reading what a build writes. Exit status 0 on success. C99. */
#include <stdio.h>

#include "cadinterp/cadinterp_builder.h"

int main(void) {
  cadinterp_build_options options;
  printf("builder %s\n", cadinterp_builder_version());
  if (cadinterp_builder_version_number() != CADINTERP_VERSION_NUMBER) {
    printf("FAIL: builder library version %u, header version %u\n",
           cadinterp_builder_version_number(), (unsigned)CADINTERP_VERSION_NUMBER);
    return 1;
  }
  cadinterp_build_options_init(&options);
  if (options.struct_size != sizeof options || options.degree != 1) {
    printf("FAIL: cadinterp_build_options_init: struct_size %zu (expected %zu), degree %d\n",
           options.struct_size, sizeof options, options.degree);
    return 1;
  }
  printf("PASS builder: version and option defaults\n");
  return 0;
}
