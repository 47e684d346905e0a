/* A minimal FMI 2.0 co-simulation host in C: proof that the FMUs run outside Python (see docs/fmu.md).
 *
 * Usage: fmi2_host FMU_DIR GUID STOP STEP OUT_VR [VR=VALUE ...]
 *   FMU_DIR  the unzipped FMU (binaries/linux64/<model>.so, resources/)
 *   GUID     the guid attribute of its modelDescription.xml
 *   OUT_VR   value reference of the Real output to print after every step
 *   VR=VALUE Real start values (parameters or inputs) to set before initialization
 * Prints "time value" lines on stdout and the FMU's log messages on stderr; exits 0 only if every call
 * returned fmi2OK and the run reached STOP. It frees the instance and returns from main: the process
 * exit runs every library's exit handlers (see docs/fmu.md, "Exit").
 *
 * Build: gcc -I <fmpy>/c-code -o fmi2_host fmi2_host.c -ldl
 *   (host_common.h, beside this file, finds and loads the FMU's binary; fmi2_host.c and fmi3_host.c share it)
 * Windows (binaries/win64/<model>.dll), cross-compiled and run under Wine as tests/test_win64.py does:
 *   x86_64-w64-mingw32-gcc -D__USE_MINGW_ANSI_STDIO=1 -I <fmpy>/c-code -o fmi2_host.exe fmi2_host.c
 * ARM Linux (FMI 2.0 has no binary folder for it: the host reads binaries/aarch64-linux/, where the FMU's
 * sources/ are compiled to), cross-compiled and run under qemu-user as tests/test_platforms.py does:
 *   python -m ziglang cc -target aarch64-linux-gnu.2.17 -I <fmpy>/c-code -o fmi2_host fmi2_host.c -ldl
 *   qemu-aarch64-static -L /usr/aarch64-linux-gnu ./fmi2_host ...
 * Run (pythonfmu FMUs need libpython in the process, and Python's own modules):
 *   LD_PRELOAD=<LIBDIR>/<INSTSONAME> PYTHONHOME=<sys.base_prefix> PYTHONPATH=<site-packages> ./fmi2_host ...
 */
#include "fmi2_host_common.h" /* the FMI 2.0 hosts' platform folder, loader, logger and CHECK */

int main(int argc, char *argv[])
{
    char real_dir[PATH_MAX];
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    double stop, step, time = 0.0, value;
    long k, steps;
    fmi2ValueReference out_vr;
    void *library;
    fmi2Component fmu;
    int usage_error;

    if (argc < 6) {
        fprintf(stderr, "usage: %s FMU_DIR GUID STOP STEP OUT_VR [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    stop = atof(argv[3]);
    step = atof(argv[4]);
    out_vr = (fmi2ValueReference)strtoul(argv[5], NULL, 10);
    library = load_fmu_binary(argv[1], real_dir);
    if (library == NULL) return 2;
    fmi2GetRealTYPE *get_real = (fmi2GetRealTYPE *)symbol(library, "fmi2GetReal");
    fmi2DoStepTYPE *do_step = (fmi2DoStepTYPE *)symbol(library, "fmi2DoStep");
    fmi2TerminateTYPE *terminate = (fmi2TerminateTYPE *)symbol(library, "fmi2Terminate");
    fmi2FreeInstanceTYPE *free_instance = (fmi2FreeInstanceTYPE *)symbol(library, "fmi2FreeInstance");

    fmu = start_fmu(library, real_dir, argv[2], fmi2CoSimulation, &callbacks, stop, 6, argc, argv, &usage_error);
    if (fmu == NULL) return usage_error ? 2 : 1;
    CHECK(get_real(fmu, &out_vr, 1, &value));
    printf("%.17g %.17g\n", time, value);
    steps = (long)(stop / step + 0.5);
    for (k = 0; k < steps; k++) {
        CHECK(do_step(fmu, time, step, fmi2True));
        time = (k + 1) * step;
        CHECK(get_real(fmu, &out_vr, 1, &value));
        printf("%.17g %.17g\n", time, value);
    }
    CHECK(terminate(fmu));
    free_instance(fmu);
    return 0; /* the library stays loaded until exit, as in fmpy */
}
