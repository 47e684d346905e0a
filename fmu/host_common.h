/* What the C hosts of this folder share (fmi2_host.c, fmi3_host.c): finding and loading the FMU's binary in an
 * unzipped FMU, on Linux (dlopen) and on Windows (LoadLibrary, when cross-compiled with MinGW-w64).
 *
 * The including host defines BINARY_FOLDER first: the folder of binaries/ its FMI version uses on this platform
 * ("linux64", "win64", "darwin64" in FMI 2.0; "x86_64-linux", "x86_64-windows", "aarch64-linux", ... in FMI 3.0).
 */
#ifndef HOST_COMMON_H
#define HOST_COMMON_H

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef BINARY_FOLDER
#error "define BINARY_FOLDER (the folder of binaries/ to load from) before including host_common.h"
#endif

#ifdef _WIN32 /* the few calls that differ on Windows */
#include <windows.h>
#define BINARY_SUFFIX ".dll"
static void *dlopen(const char *path, int flags) { (void)flags; return (void *)LoadLibraryA(path); }
static void *dlsym(void *library, const char *name) { return (void *)GetProcAddress((HMODULE)library, name); }
static const char *dlerror(void) { return "LoadLibrary failed"; }
static char *realpath(const char *path, char *resolved) { return _fullpath(resolved, path, PATH_MAX); }
#define RTLD_NOW 0
#define RTLD_LOCAL 0
#elif defined(__APPLE__)
#include <dlfcn.h>
#define BINARY_SUFFIX ".dylib"
#else
#include <dlfcn.h>
#define BINARY_SUFFIX ".so"
#endif

/* the address of an FMI function of the library; a missing one ends the host (exit status 2) */
static void *symbol(void *library, const char *name)
{
    void *address = dlsym(library, name);
    if (address == NULL) {
        fprintf(stderr, "missing FMI function %s\n", name);
        exit(2);
    }
    return address;
}

/* the first *.so (*.dll on Windows) in FMU_DIR/binaries/BINARY_FOLDER */
static int find_library(const char *fmu_dir, char *path, size_t size)
{
    char folder[PATH_MAX + 32];
    struct dirent *entry;
    DIR *dir;
    snprintf(folder, sizeof folder, "%s/binaries/" BINARY_FOLDER, fmu_dir);
    dir = opendir(folder);
    if (dir == NULL) return -1;
    while ((entry = readdir(dir)) != NULL) {
        size_t n = strlen(entry->d_name);
        if (n > strlen(BINARY_SUFFIX) && strcmp(entry->d_name + n - strlen(BINARY_SUFFIX), BINARY_SUFFIX) == 0) {
            snprintf(path, size, "%s/%s", folder, entry->d_name);
            closedir(dir);
            return 0;
        }
    }
    closedir(dir);
    return -1;
}

/* The FMU's binary in the unzipped FMU fmu_dir, loaded, with fmu_dir's absolute path in real_dir (PATH_MAX
 * characters); NULL, after a line on stderr, when there is none or it does not load. */
static void *load_fmu_binary(const char *fmu_dir, char *real_dir)
{
    char library_path[PATH_MAX + 64];
    void *library;
    if (realpath(fmu_dir, real_dir) == NULL || find_library(real_dir, library_path, sizeof library_path) != 0) {
        fprintf(stderr, "no binaries/" BINARY_FOLDER "/*" BINARY_SUFFIX " in %s\n", fmu_dir);
        return NULL;
    }
    library = dlopen(library_path, RTLD_NOW | RTLD_LOCAL);
    if (library == NULL) fprintf(stderr, "dlopen failed: %s\n", dlerror());
    return library;
}

#endif
