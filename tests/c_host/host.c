/*
 * A minimal FMI 2.0 co-simulation host in C, as FMU checkers and C/C++ tools are: it dlopens
 * an extracted FMU's binaries/linux64/<id>.so with RTLD_NOW | RTLD_LOCAL (nothing of Python
 * is loaded in this process beforehand), runs it and prints the outputs as CSV.
 *
 *   host FMU_DIR MODEL_ID GUID N_STEPS STEP_SIZE [-i VR=a[,b,c,d,w]]... [-o TYPE:VR]...
 *
 * -i sets Real input VR to a + b t + c sin(w t) + d cos(w t) (t: the communication point),
 * in initialisation mode (t = 0) and before every step. -o prints output VR of TYPE r (Real),
 * i (Integer) or b (Boolean): one CSV row "time,outputs..." after initialisation and after
 * every step (%.17g: doubles round-trip exactly). Exit status: 0 when every call returned
 * fmi2OK or fmi2Warning; 1 for a failed call (named on stderr); 2 for bad arguments or an FMU
 * that cannot be loaded. At the end it names on stderr every libpython in the process
 * ("host: loaded /path/libpython3.x.so.1.0"), the one the FMU's loader found, and the time
 * time from dlopen to the return of fmi2Instantiate (loading libpython and starting it).
 */

#define _GNU_SOURCE
#define HOST_NAME "host"
#include <limits.h>
#include <stdarg.h>

#include "fmi2Functions.h"
#include "host_common.h"


static void logger(fmi2ComponentEnvironment environment, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    va_list args;
    (void)environment;
    fprintf(stderr, "[%s] %s status %d: ", category ? category : "", instance ? instance : "",
            (int)status);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

#define CHECK(call) \
    do { \
        fmi2Status status_ = (call); \
        if (status_ > fmi2Warning) { \
            fprintf(stderr, "host: %s returned status %d at t = %.17g\n", #call, (int)status_, \
                    t); \
            failed = 1; \
            goto done; \
        } \
    } while (0)

int main(int argc, char **argv)
{
    static Input inputs[MAX_VARIABLES];
    static Output outputs[MAX_VARIABLES];
    int n_inputs = 0, n_outputs = 0, failed = 0, i;
    long n_steps, step;
    double h, t = 0.0;
    char directory[PATH_MAX], path[PATH_MAX + 64], resources[PATH_MAX + 64];
    void *library;
    struct timespec before, after;
    fmi2Component c = NULL;
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

    if (argc < 6) {
        fprintf(stderr, "usage: %s FMU_DIR MODEL_ID GUID N_STEPS STEP_SIZE "
                        "[-i VR=a[,b,c,d,w]]... [-o TYPE:VR]...\n", argv[0]);
        return 2;
    }
    n_steps = strtol(argv[4], NULL, 10);
    h = strtod(argv[5], NULL);
    for (i = 6; i < argc; i++) {
        if (strcmp(argv[i], "-i") == 0 && i + 1 < argc && n_inputs < MAX_VARIABLES) {
            if (!parse_input(argv[++i], &inputs[n_inputs++])) return 2;
        } else if (strcmp(argv[i], "-o") == 0 && i + 1 < argc && n_outputs < MAX_VARIABLES) {
            if (!parse_output(argv[++i], &outputs[n_outputs++])) return 2;
        } else {
            fprintf(stderr, "host: bad argument '%s'\n", argv[i]);
            return 2;
        }
    }
    if (!realpath(argv[1], directory)) {
        perror(argv[1]);
        return 2;
    }
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", directory, argv[2]);
    snprintf(resources, sizeof resources, "file://%s/resources", directory);

    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) { /* this host must start without Python */
        fprintf(stderr, "host: the Python C API is already loaded in this process\n");
        return 2;
    }
    clock_gettime(CLOCK_MONOTONIC, &before);
    library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "host: cannot load %s: %s\n", path, dlerror());
        return 2;
    }
    {
        fmi2InstantiateTYPE *instantiate = resolve(library, "fmi2Instantiate");
        fmi2FreeInstanceTYPE *freeInstance = resolve(library, "fmi2FreeInstance");
        fmi2SetupExperimentTYPE *setupExperiment = resolve(library, "fmi2SetupExperiment");
        fmi2EnterInitializationModeTYPE *enterInitializationMode =
            resolve(library, "fmi2EnterInitializationMode");
        fmi2ExitInitializationModeTYPE *exitInitializationMode =
            resolve(library, "fmi2ExitInitializationMode");
        fmi2SetRealTYPE *setReal = resolve(library, "fmi2SetReal");
        fmi2GetRealTYPE *getReal = resolve(library, "fmi2GetReal");
        fmi2GetIntegerTYPE *getInteger = resolve(library, "fmi2GetInteger");
        fmi2GetBooleanTYPE *getBoolean = resolve(library, "fmi2GetBoolean");
        fmi2DoStepTYPE *doStep = resolve(library, "fmi2DoStep");
        fmi2TerminateTYPE *terminate = resolve(library, "fmi2Terminate");
        fmi2GetVersionTYPE *getVersion = resolve(library, "fmi2GetVersion");

        if (strcmp(getVersion(), "2.0") != 0) {
            fprintf(stderr, "host: fmi2GetVersion returned '%s'\n", getVersion());
            return 2;
        }
        c = instantiate("c_host", fmi2CoSimulation, argv[3], resources, &callbacks, fmi2False,
                        fmi2True);
        clock_gettime(CLOCK_MONOTONIC, &after);
        fprintf(stderr, "host: dlopen to fmi2Instantiate took %.4f s\n",
                seconds_between(&before, &after));
        if (!c) {
            fprintf(stderr, "host: fmi2Instantiate returned NULL\n");
            return 2;
        }
        CHECK(setupExperiment(c, fmi2False, 0.0, t, fmi2False, 0.0));
        CHECK(enterInitializationMode(c));
        for (i = 0; i < n_inputs; i++) {
            fmi2Real value = input_value(&inputs[i], t);
            CHECK(setReal(c, &inputs[i].vr, 1, &value));
        }
        CHECK(exitInitializationMode(c));
        for (step = 0; step <= n_steps; step++) {
            if (step > 0) {
                for (i = 0; i < n_inputs; i++) {
                    fmi2Real value = input_value(&inputs[i], t);
                    CHECK(setReal(c, &inputs[i].vr, 1, &value));
                }
                CHECK(doStep(c, t, h, fmi2True));
                t += h;
            }
            printf("%.17g", t);
            for (i = 0; i < n_outputs; i++) {
                fmi2Real real;
                fmi2Integer integer;
                fmi2Boolean boolean;
                switch (outputs[i].type) {
                case 'r':
                    CHECK(getReal(c, &outputs[i].vr, 1, &real));
                    printf(",%.17g", real);
                    break;
                case 'i':
                    CHECK(getInteger(c, &outputs[i].vr, 1, &integer));
                    printf(",%d", integer);
                    break;
                default:
                    CHECK(getBoolean(c, &outputs[i].vr, 1, &boolean));
                    printf(",%d", boolean ? 1 : 0);
                }
            }
            printf("\n");
        }
        CHECK(terminate(c));
    done:
        freeInstance(c);
    }
    fflush(stdout);
    dl_iterate_phdr(name_libpython, NULL);
    return failed;
}
