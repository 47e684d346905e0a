/* What the FMI 2.0 hosts share (fmi2_host.c: Co-Simulation; fmi2_me_host.c: Model Exchange): the binary
 * folder of this platform, finding and loading the binary (host_common.h), the logger and CHECK. */
#ifndef FMI2_HOST_COMMON_H
#define FMI2_HOST_COMMON_H
#include <stdarg.h>
#include "fmi2Functions.h"

#if defined(_WIN32)
#define BINARY_FOLDER "win64"
#elif defined(__APPLE__)
#define BINARY_FOLDER "darwin64"
#elif defined(__aarch64__) /* FMI 2.0 has no name for ARM Linux: FMI 3.0's, for the compiled sources */
#define BINARY_FOLDER "aarch64-linux"
#else
#define BINARY_FOLDER "linux64"
#endif
#include "host_common.h" /* finding and loading the binary, on Linux and Windows */

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list args;
    (void)env;
    fprintf(stderr, "[%s] status %d %s: ", instance, (int)status, category);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

#define CHECK(call)                                                            \
    do {                                                                       \
        fmi2Status status_ = (call);                                           \
        if (status_ != fmi2OK) {                                               \
            fprintf(stderr, "%s returned status %d\n", #call, (int)status_);   \
            return 1;                                                          \
        }                                                                      \
    } while (0)

#endif
