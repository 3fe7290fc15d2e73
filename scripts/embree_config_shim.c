/* LD_PRELOAD shim for timing Embree (an oracle, never used by tests or CI), since embreex
 * offers neither a device configuration nor a build quality:
 *  - rtcNewDevice gets the configuration string in $EMBREE_CONFIG (e.g. "isa=avx2") instead
 *    of the caller's;
 *  - with $EMBREE_QUALITY set (low, medium, high), every geometry and scene gets that build
 *    quality just before it is committed (RTC_BUILD_QUALITY_HIGH is what Mitsuba 3 asks
 *    for: Embree's spatial-split builder).
 * $EMBREE_LIB names the Embree library to forward to.
 *   cc -shared -fPIC -O2 -o /tmp/embree_config_shim.so scripts/embree_config_shim.c -ldl */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Embree's own function `name`, from $EMBREE_LIB (or the next library that has it). */
static void *real(const char *name) {
    const char *lib = getenv("EMBREE_LIB");
    void *h = lib ? dlopen(lib, RTLD_NOW | RTLD_NOLOAD) : NULL;
    void *f = h ? dlsym(h, name) : dlsym(RTLD_NEXT, name);
    if (!f) {
        fprintf(stderr, "embree_config_shim: no %s (set EMBREE_LIB)\n", name);
        abort();
    }
    return f;
}

/* RTCBuildQuality of $EMBREE_QUALITY: 0 low, 1 medium, 2 high; -1 unset. */
static int quality(void) {
    const char *q = getenv("EMBREE_QUALITY");
    if (!q || !*q) return -1;
    if (!strcmp(q, "low")) return 0;
    if (!strcmp(q, "medium")) return 1;
    if (!strcmp(q, "high")) return 2;
    fprintf(stderr, "embree_config_shim: EMBREE_QUALITY=%s is not low, medium or high\n", q);
    abort();
}

void *rtcNewDevice(const char *config) {
    static void *(*f)(const char *);
    if (!f) f = (void *(*)(const char *))real("rtcNewDevice");
    const char *c = getenv("EMBREE_CONFIG");
    return f(c ? c : config);
}

/* Gives `obj` the build quality $EMBREE_QUALITY names (if any) with Embree's `setter`, then
 * commits it with Embree's `commit` (looked up per call: commits are few). */
static void commit_with_quality(const char *commit, const char *setter, void *obj) {
    if (quality() >= 0) ((void (*)(void *, int))real(setter))(obj, quality());
    ((void (*)(void *))real(commit))(obj);
}

void rtcCommitGeometry(void *geometry) { commit_with_quality("rtcCommitGeometry", "rtcSetGeometryBuildQuality", geometry); }

void rtcCommitScene(void *scene) { commit_with_quality("rtcCommitScene", "rtcSetSceneBuildQuality", scene); }
