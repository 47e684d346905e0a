/* A minimal FMI 3.0 co-simulation host in C: the FMI 3.0 FMUs of dist/fmi3 run with no Python (see docs/fmu.md).
 *
 * Usage: fmi3_host FMU_DIR TOKEN STOP STEP OUT_VR [VR=VALUE ...]
 *   FMU_DIR  the unzipped FMU (binaries/x86_64-linux/<model>.so, or binaries/x86_64-windows/<model>.dll on Windows)
 *   TOKEN    the instantiationToken attribute of its modelDescription.xml
 *   OUT_VR   value reference of the Float64 output to print after every step
 *   VR=VALUE Float64 start values (parameters or inputs) to set in initialization mode
 * Prints "time value" lines on stdout and the FMU's log messages on stderr; exits 0 only if every call
 * returned fmi3OK and the run reached STOP (fmi3DoStep asking to terminate is a failure too).
 *
 * Build: gcc -I <fmpy>/c-code -o fmi3_host fmi3_host.c -ldl
 *   (host_common.h, beside this file, finds and loads the FMU's binary; fmi2_host.c and fmi3_host.c share it)
 * Windows: x86_64-w64-mingw32-gcc -D__USE_MINGW_ANSI_STDIO=1 -I <fmpy>/c-code -o fmi3_host.exe fmi3_host.c
 * ARM Linux (binaries/aarch64-linux/<model>.so), run under qemu-user as tests/test_platforms.py does:
 *   python -m ziglang cc -target aarch64-linux-gnu.2.17 -I <fmpy>/c-code -o fmi3_host fmi3_host.c -ldl
 *   qemu-aarch64-static -L /usr/aarch64-linux-gnu ./fmi3_host ...
 */
#include "fmi3Functions.h"

#if defined(_WIN32)
#define BINARY_FOLDER "x86_64-windows"
#elif defined(__APPLE__) && defined(__aarch64__)
#define BINARY_FOLDER "aarch64-darwin"
#elif defined(__APPLE__)
#define BINARY_FOLDER "x86_64-darwin"
#elif defined(__aarch64__)
#define BINARY_FOLDER "aarch64-linux"
#else
#define BINARY_FOLDER "x86_64-linux"
#endif
#include "host_common.h" /* finding and loading the binary, on Linux and Windows */

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env;
    fprintf(stderr, "[host] status %d %s: %s\n", (int)status, category, message);
}

#define CHECK(call)                                                            \
    do {                                                                       \
        fmi3Status status_ = (call);                                           \
        if (status_ != fmi3OK) {                                               \
            fprintf(stderr, "%s returned status %d\n", #call, (int)status_);   \
            return 1;                                                          \
        }                                                                      \
    } while (0)

int main(int argc, char *argv[])
{
    char resources[PATH_MAX + 64], real_dir[PATH_MAX];
    double stop, step, time = 0.0, value, last;
    fmi3Boolean event, terminate_run, early;
    long k, steps;
    fmi3ValueReference out_vr;
    void *library;
    fmi3Instance fmu;
    int i;

    if (argc < 6) {
        fprintf(stderr, "usage: %s FMU_DIR TOKEN STOP STEP OUT_VR [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    stop = atof(argv[3]);
    step = atof(argv[4]);
    out_vr = (fmi3ValueReference)strtoul(argv[5], NULL, 10);
    library = load_fmu_binary(argv[1], real_dir);
    if (library == NULL) return 2;
    fmi3InstantiateCoSimulationTYPE *instantiate =
        (fmi3InstantiateCoSimulationTYPE *)symbol(library, "fmi3InstantiateCoSimulation");
    fmi3EnterInitializationModeTYPE *enter = (fmi3EnterInitializationModeTYPE *)symbol(library, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *leave = (fmi3ExitInitializationModeTYPE *)symbol(library, "fmi3ExitInitializationMode");
    fmi3SetFloat64TYPE *set_float = (fmi3SetFloat64TYPE *)symbol(library, "fmi3SetFloat64");
    fmi3GetFloat64TYPE *get_float = (fmi3GetFloat64TYPE *)symbol(library, "fmi3GetFloat64");
    fmi3DoStepTYPE *do_step = (fmi3DoStepTYPE *)symbol(library, "fmi3DoStep");
    fmi3TerminateTYPE *terminate = (fmi3TerminateTYPE *)symbol(library, "fmi3Terminate");
    fmi3FreeInstanceTYPE *free_instance = (fmi3FreeInstanceTYPE *)symbol(library, "fmi3FreeInstance");

    snprintf(resources, sizeof resources, "%s/resources/", real_dir); /* FMI 3.0: a path, not a URI */
    fmu = instantiate("host", argv[2], resources, fmi3False, fmi3True, fmi3False, fmi3False, NULL, 0, NULL, logger,
                      NULL);
    if (fmu == NULL) {
        fprintf(stderr, "fmi3InstantiateCoSimulation failed\n");
        return 1;
    }
    CHECK(enter(fmu, fmi3False, 0.0, 0.0, fmi3True, stop));
    for (i = 6; i < argc; i++) {
        fmi3ValueReference vr;
        if (sscanf(argv[i], "%u=%lf", &vr, &value) != 2) {
            fprintf(stderr, "bad start value %s (want VR=VALUE)\n", argv[i]);
            return 2;
        }
        CHECK(set_float(fmu, &vr, 1, &value, 1));
    }
    CHECK(leave(fmu));
    CHECK(get_float(fmu, &out_vr, 1, &value, 1));
    printf("%.17g %.17g\n", time, value);
    steps = (long)(stop / step + 0.5);
    for (k = 0; k < steps; k++) {
        CHECK(do_step(fmu, time, step, fmi3True, &event, &terminate_run, &early, &last));
        if (terminate_run) {
            fprintf(stderr, "fmi3DoStep asked to terminate at t = %g s\n", last);
            return 1;
        }
        time = (k + 1) * step;
        CHECK(get_float(fmu, &out_vr, 1, &value, 1));
        printf("%.17g %.17g\n", time, value);
    }
    CHECK(terminate(fmu));
    free_instance(fmu);
    return 0; /* the library stays loaded until exit */
}
