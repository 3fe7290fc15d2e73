/* LD_PRELOAD shim for timing Embree (an oracle, never used by tests or CI): rtcNewDevice gets
 * the configuration string in $EMBREE_CONFIG (e.g. "isa=avx2") instead of the caller's, since
 * embreex creates its device without one. $EMBREE_LIB names the Embree library to forward to.
 *   cc -shared -fPIC -O2 -o /tmp/embree_config_shim.so scripts/embree_config_shim.c -ldl */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

void *rtcNewDevice(const char *config) {
    static void *(*real)(const char *);
    if (!real) {
        const char *lib = getenv("EMBREE_LIB");
        void *h = lib ? dlopen(lib, RTLD_NOW | RTLD_NOLOAD) : NULL;
        real = (void *(*)(const char *))(h ? dlsym(h, "rtcNewDevice") : dlsym(RTLD_NEXT, "rtcNewDevice"));
        if (!real) {
            fprintf(stderr, "embree_config_shim: no rtcNewDevice (set EMBREE_LIB)\n");
            abort();
        }
    }
    const char *c = getenv("EMBREE_CONFIG");
    return real(c ? c : config);
}
