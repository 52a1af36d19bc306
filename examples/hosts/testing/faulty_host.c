/* A host library that crashes on purpose, for the tests of `cadinterp build --isolate`: it loads
 * another host library (the analytic host by default) and passes every callback through to it,
 * except that regenerate fails hard at chosen points:
 *
 *   segv=LO:HI   a write through a null pointer (SIGSEGV)
 *   abort=LO:HI  abort() (SIGABRT)
 *   hang=LO:HI   sleeps forever (only a timeout ends it)
 *   leak=LO:HI   allocates and touches 16 MiB blocks without bound; when malloc fails it aborts,
 *                as a kernel with an xmalloc-style allocator does (with no address-space limit,
 *                it stops at 4 GiB and aborts, so a mistake cannot take the machine down)
 *
 * A point is affected when its first parameter, scaled to [0, 1] over the parameter's range,
 * lies in [LO, HI]. A window LO:HI:LO1:HI1 also needs the second parameter, scaled alike, in
 * [LO1, HI1]. The windows are tested in the order above. Further options:
 *   log=PATH     appends "x0 x1 ...\n" (%.17g) to PATH at every regenerate call, before any
 *                fault, so a test counts the calls per point (retries included)
 *   inner=PATH   the wrapped host library (default: the analytic host of this build tree)
 * Every other option, and the model, go to the wrapped host. The host's name is the wrapped one's;
 * its identity adds the fault options, so a sample store never mixes the two.
 *
 * Test-only: built with the tests, never installed. Linux/POSIX (dlopen).
 */
#define _POSIX_C_SOURCE 200809L

#include <dlfcn.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "cadinterp/cadinterp_builder.h"

#if defined(__GNUC__) || defined(__clang__)
#define FAULTY_EXPORT __attribute__((visibility("default")))
#else
#define FAULTY_EXPORT
#endif

enum { SEGV, ABORT, HANG, LEAK, FAULT_KINDS };
static const char* const kFaultNames[FAULT_KINDS] = {"segv", "abort", "hang", "leak"};

typedef struct faulty {
  cadinterp_host host; /* what the entry returns: the inner host with regenerate wrapped */
  const cadinterp_host* inner;
  double window[FAULT_KINDS][4]; /* [LO, HI] of parameter 0, [LO1, HI1] of 1; LO > HI: none */
  char log_path[1024];
  char identity[2048];
} faulty;

/* One host per library load: the tests load one configuration per process. */
static faulty g_faulty;
static void* g_inner_library = NULL;
static pthread_mutex_t g_lock = PTHREAD_MUTEX_INITIALIZER;

static void log_call(const faulty* f, const double* x) {
  char line[1024];
  size_t n = 0;
  int i, fd;
  if (!f->log_path[0]) return;
  for (i = 0; i < f->inner->parameter_count && n < sizeof line - 32; ++i)
    n += (size_t)snprintf(line + n, sizeof line - n, "%s%.17g", i ? " " : "", x[i]);
  line[n++] = '\n';
  /* O_APPEND: each call's line is one write, whole, whatever other workers write. */
  fd = open(f->log_path, O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd >= 0) {
    if (write(fd, line, n) != (ssize_t)n) perror("faulty host: log");
    close(fd);
  }
}

static void leak_until_out_of_memory(void) {
  const size_t block = (size_t)16 << 20;
  struct rlimit limit;
  size_t total = 0;
  const int bounded = getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY;
  for (;;) {
    char* p = (char*)malloc(block);
    if (!p || (!bounded && total >= ((size_t)4 << 30))) {
      fprintf(stderr, "faulty host: out of memory after %zu MiB\n", total >> 20);
      abort();
    }
    memset(p, 1, block);
    total += block;
  }
}

/* A null pointer the compiler cannot see through, so the write below is a real invalid write
 * (with a local NULL, GCC drops the store as undefined behaviour). */
int* volatile faulty_null_pointer = NULL;

static void fail_hard(int kind) {
  switch (kind) {
    case SEGV:
      *faulty_null_pointer = 1;
      break;
    case ABORT:
      abort();
    case HANG:
      for (;;) pause();
    case LEAK:
      leak_until_out_of_memory();
      break;
    default:
      break;
  }
}

static double scaled(const faulty* f, const double* x, int i) {
  const cadinterp_parameter_desc* p = &f->inner->parameters[i];
  return (x[i] - p->lower) / (p->upper - p->lower);
}

static cadinterp_status faulty_regenerate(void* user, const double* x, cadinterp_sample* out) {
  const faulty* f = (const faulty*)user;
  const double t0 = scaled(f, x, 0);
  const double t1 = f->inner->parameter_count > 1 ? scaled(f, x, 1) : 0;
  int kind;
  log_call(f, x);
  for (kind = 0; kind < FAULT_KINDS; ++kind) {
    const double* w = f->window[kind];
    if (w[0] <= t0 && t0 <= w[1] && w[2] <= t1 && t1 <= w[3]) fail_hard(kind);
  }
  return f->inner->regenerate(f->inner->user, x, out);
}

static cadinterp_status faulty_references(void* user, const double* x, cadinterp_sample* out) {
  const faulty* f = (const faulty*)user;
  return f->inner->references(f->inner->user, x, out);
}

static cadinterp_status faulty_simulate(void* user, const double* x,
                                        const cadinterp_host_mesh* mesh, cadinterp_sample* out) {
  const faulty* f = (const faulty*)user;
  return f->inner->simulate(f->inner->user, x, mesh, out);
}

/* Takes the faulty host's own options out of `options` into f; the rest goes to `inner_options`.
 * Returns a static message on a malformed option, else NULL. */
static const char* parse_options(const char* options, faulty* f, char* inner_path,
                                 size_t inner_path_size, char* inner_options,
                                 size_t inner_options_size) {
  char buffer[4096];
  char* save = NULL;
  char* item;
  int kind;
  size_t used = 0;
  if (strlen(options) >= sizeof buffer) return "faulty host: options too long";
  strcpy(buffer, options);
  inner_options[0] = '\0';
  for (item = strtok_r(buffer, ",", &save); item; item = strtok_r(NULL, ",", &save)) {
    char* value = strchr(item, '=');
    int mine = 0;
    if (!value) return "faulty host: an option is not KEY=VALUE";
    *value++ = '\0';
    for (kind = 0; kind < FAULT_KINDS; ++kind)
      if (strcmp(item, kFaultNames[kind]) == 0) {
        double* w = f->window[kind];
        const int n = sscanf(value, "%lf:%lf:%lf:%lf", &w[0], &w[1], &w[2], &w[3]);
        if (n != 2 && n != 4) return "faulty host: a fault window is not LO:HI or LO:HI:LO1:HI1";
        mine = 1;
      }
    if (strcmp(item, "log") == 0) {
      if (strlen(value) >= sizeof f->log_path) return "faulty host: log path too long";
      strcpy(f->log_path, value);
      mine = 1;
    } else if (strcmp(item, "inner") == 0) {
      if (strlen(value) >= inner_path_size) return "faulty host: inner path too long";
      strcpy(inner_path, value);
      mine = 1;
    }
    if (!mine) {
      const int n = snprintf(inner_options + used, inner_options_size - used, "%s%s=%s",
                             used ? "," : "", item, value);
      if (n < 0 || (size_t)n >= inner_options_size - used) return "faulty host: options too long";
      used += (size_t)n;
    }
  }
  return NULL;
}

static const cadinterp_host* load_inner(const char* path, const char* model, const char* options,
                                        const char** error) {
  cadinterp_host_entry_fn entry;
  void* symbol;
  g_inner_library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!g_inner_library) {
    *error = "faulty host: cannot load the inner host library";
    return NULL;
  }
  symbol = dlsym(g_inner_library, CADINTERP_HOST_ENTRY_NAME);
  if (!symbol) {
    *error = "faulty host: the inner library has no " CADINTERP_HOST_ENTRY_NAME;
    return NULL;
  }
  memcpy(&entry, &symbol, sizeof entry); /* POSIX: dlsym's pointer is usable as a function */
  return entry(model, options[0] ? options : NULL, error);
}

FAULTY_EXPORT const cadinterp_host* cadinterp_host_entry(const char* model, const char* options,
                                                         const char** error) {
  char inner_path[1024] = FAULTY_DEFAULT_INNER;
  char inner_options[4096];
  const char* message = NULL;
  const cadinterp_host* result = NULL;
  const char* ignored = NULL;
  int kind;
  if (!error) error = &ignored;
  pthread_mutex_lock(&g_lock);
  if (g_faulty.inner) {
    *error = "faulty host: one host per library load";
  } else {
    faulty f;
    memset(&f, 0, sizeof f);
    for (kind = 0; kind < FAULT_KINDS; ++kind) {
      f.window[kind][0] = 1;
      f.window[kind][1] = 0;
      f.window[kind][2] = 0;
      f.window[kind][3] = 1;
    }
    message = parse_options(options ? options : "", &f, inner_path, sizeof inner_path,
                            inner_options, sizeof inner_options);
    if (message) *error = message;
    if (!message && (f.inner = load_inner(inner_path, model, inner_options, error)) != NULL) {
      g_faulty = f;
      g_faulty.host = *f.inner;
      snprintf(g_faulty.identity, sizeof g_faulty.identity, "%s; faulty(%s)",
               f.inner->identity ? f.inner->identity : "", options ? options : "");
      g_faulty.host.identity = g_faulty.identity;
      g_faulty.host.user = &g_faulty;
      g_faulty.host.regenerate = faulty_regenerate;
      g_faulty.host.references = f.inner->references ? faulty_references : NULL;
      g_faulty.host.simulate = f.inner->simulate ? faulty_simulate : NULL;
      result = &g_faulty.host;
    }
  }
  pthread_mutex_unlock(&g_lock);
  return result;
}
