/*
 * A minimal FMI 3.0 co-simulation host in C (the FMI 3 twin of host.c): it dlopens extracted
 * FMUs' binaries/x86_64-linux/<id>.so with RTLD_NOW | RTLD_LOCAL in a process without Python,
 * runs them side by side with the same communication steps and prints their outputs as CSV.
 *
 *   host3 N_STEPS STEP_SIZE [--release-first-after K] [--reload-first]
 *         -f FMU_DIR MODEL_ID TOKEN [-i VR=a[,b,c,d,w]]... [-o TYPE:VR]...  [-f ...]...
 *
 * Each -f starts an FMU; the -i and -o after it are its own. -i sets Float64 input VR to
 * a + b t + c sin(w t) + d cos(w t) in initialisation mode (t = 0) and before every step;
 * -o prints output VR of TYPE r (Float64), i (Int32) or b (Boolean). Rows are
 * "FMU,time,outputs..." (FMU: the index of its -f, from 0), after initialisation and after
 * every step, %.17g. --release-first-after K terminates, frees and unloads (dlclose) the first
 * FMU after step K while the others go on; --reload-first loads the first FMU again after
 * all are unloaded and runs it once more from the start (rows "R,time,..."). Exit status: 0
 * when every call returned OK or Warning; 1 for a failed call (named on stderr); 2 for bad
 * arguments or an FMU that cannot be loaded. At the end it names on stderr every libpython in
 * the process ("host3: loaded /path/libpython3.x.so.1.0").
 */

#define _GNU_SOURCE
#define HOST_NAME "host3"
#include <limits.h>

#include "fmi3Functions.h"
#include "host_common.h"

#define MAX_FMUS 8

typedef struct {
    const char *directory, *id, *token;
    Input inputs[MAX_VARIABLES];
    Output outputs[MAX_VARIABLES];
    int n_inputs, n_outputs;
    void *library;
    fmi3Instance instance;
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *freeInstance;
    fmi3EnterInitializationModeTYPE *enterInitializationMode;
    fmi3ExitInitializationModeTYPE *exitInitializationMode;
    fmi3SetFloat64TYPE *setFloat64;
    fmi3GetFloat64TYPE *getFloat64;
    fmi3GetInt32TYPE *getInt32;
    fmi3GetBooleanTYPE *getBoolean;
    fmi3DoStepTYPE *doStep;
    fmi3TerminateTYPE *terminate;
    fmi3GetVersionTYPE *getVersion;
} Fmu;

static void logger(fmi3InstanceEnvironment environment, fmi3Status status,
                   fmi3String category, fmi3String message)
{
    fprintf(stderr, "[%s] %s status %d: %s\n", category ? category : "",
            environment ? (const char *)environment : "", (int)status, message);
}

/* Loads and instantiates one FMU and takes it through initialisation at t = 0; 0 when it
 * failed (named on stderr). */
static int start(Fmu *fmu)
{
    char directory[PATH_MAX], path[PATH_MAX + 64], resources[PATH_MAX + 64];
    struct timespec before, after;
    int i;
    if (!realpath(fmu->directory, directory)) {
        perror(fmu->directory);
        return 0;
    }
    snprintf(path, sizeof path, "%s/binaries/x86_64-linux/%s.so", directory, fmu->id);
    snprintf(resources, sizeof resources, "%s/resources/", directory);
    clock_gettime(CLOCK_MONOTONIC, &before);
    fmu->library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!fmu->library) {
        fprintf(stderr, "host3: cannot load %s: %s\n", path, dlerror());
        return 0;
    }
    fmu->instantiate = resolve(fmu->library, "fmi3InstantiateCoSimulation");
    fmu->freeInstance = resolve(fmu->library, "fmi3FreeInstance");
    fmu->enterInitializationMode = resolve(fmu->library, "fmi3EnterInitializationMode");
    fmu->exitInitializationMode = resolve(fmu->library, "fmi3ExitInitializationMode");
    fmu->setFloat64 = resolve(fmu->library, "fmi3SetFloat64");
    fmu->getFloat64 = resolve(fmu->library, "fmi3GetFloat64");
    fmu->getInt32 = resolve(fmu->library, "fmi3GetInt32");
    fmu->getBoolean = resolve(fmu->library, "fmi3GetBoolean");
    fmu->doStep = resolve(fmu->library, "fmi3DoStep");
    fmu->terminate = resolve(fmu->library, "fmi3Terminate");
    fmu->getVersion = resolve(fmu->library, "fmi3GetVersion");
    if (strcmp(fmu->getVersion(), "3.0") != 0) {
        fprintf(stderr, "host3: fmi3GetVersion returned '%s'\n", fmu->getVersion());
        return 0;
    }
    fmu->instance = fmu->instantiate(fmu->id, fmu->token, resources, fmi3False, fmi3True,
                                     fmi3False, fmi3False, NULL, 0, (void *)fmu->id, logger,
                                     NULL);
    clock_gettime(CLOCK_MONOTONIC, &after);
    fprintf(stderr, "host3: %s: dlopen to fmi3InstantiateCoSimulation took %.4f s\n", fmu->id,
            seconds_between(&before, &after));
    if (!fmu->instance) {
        fprintf(stderr, "host3: fmi3InstantiateCoSimulation returned NULL\n");
        return 0;
    }
    if (fmu->enterInitializationMode(fmu->instance, fmi3False, 0.0, 0.0, fmi3False, 0.0)
        > fmi3Warning) {
        fprintf(stderr, "host3: fmi3EnterInitializationMode failed\n");
        return 0;
    }
    for (i = 0; i < fmu->n_inputs; i++) {
        fmi3Float64 value = input_value(&fmu->inputs[i], 0.0);
        if (fmu->setFloat64(fmu->instance, &fmu->inputs[i].vr, 1, &value, 1) > fmi3Warning) {
            fprintf(stderr, "host3: fmi3SetFloat64 failed at t = 0\n");
            return 0;
        }
    }
    if (fmu->exitInitializationMode(fmu->instance) > fmi3Warning) {
        fprintf(stderr, "host3: fmi3ExitInitializationMode failed\n");
        return 0;
    }
    return 1;
}

/* One communication step from t (none when step_size is 0) and its row; 0 on a failed call. */
static int step(Fmu *fmu, const char *label, double t, double step_size)
{
    fmi3Boolean event, terminate, early;
    fmi3Float64 reached;
    int i;
    if (step_size > 0.0) {
        for (i = 0; i < fmu->n_inputs; i++) {
            fmi3Float64 value = input_value(&fmu->inputs[i], t);
            if (fmu->setFloat64(fmu->instance, &fmu->inputs[i].vr, 1, &value, 1) > fmi3Warning) {
                fprintf(stderr, "host3: %s fmi3SetFloat64 failed at t = %.17g\n", label, t);
                return 0;
            }
        }
        if (fmu->doStep(fmu->instance, t, step_size, fmi3True, &event, &terminate, &early,
                        &reached) > fmi3Warning) {
            fprintf(stderr, "host3: %s fmi3DoStep failed at t = %.17g\n", label, t);
            return 0;
        }
        t += step_size;
    }
    printf("%s,%.17g", label, t);
    for (i = 0; i < fmu->n_outputs; i++) {
        const Output *output = &fmu->outputs[i];
        fmi3Float64 real;
        fmi3Int32 integer;
        fmi3Boolean boolean;
        fmi3Status status;
        switch (output->type) {
        case 'r':
            status = fmu->getFloat64(fmu->instance, &output->vr, 1, &real, 1);
            printf(",%.17g", real);
            break;
        case 'i':
            status = fmu->getInt32(fmu->instance, &output->vr, 1, &integer, 1);
            printf(",%d", integer);
            break;
        default:
            status = fmu->getBoolean(fmu->instance, &output->vr, 1, &boolean, 1);
            printf(",%d", boolean ? 1 : 0);
        }
        if (status > fmi3Warning) {
            fprintf(stderr, "host3: %s getting output %u failed\n", label, output->vr);
            return 0;
        }
    }
    printf("\n");
    return 1;
}

static void stop(Fmu *fmu)
{
    if (fmu->instance) {
        fmu->terminate(fmu->instance);
        fmu->freeInstance(fmu->instance);
    }
    fmu->instance = NULL;
    if (fmu->library) dlclose(fmu->library);
    fmu->library = NULL;
}

static int run_alone(Fmu *fmu, const char *label, long n_steps, double h)
{
    long k;
    double t = 0.0;
    if (!start(fmu) || !step(fmu, label, t, 0.0)) return 0;
    for (k = 1; k <= n_steps; k++, t += h) {
        if (!step(fmu, label, t, h)) return 0;
    }
    stop(fmu);
    return 1;
}

static int parse(int argc, char **argv, Fmu *fmus, int *n_fmus, long *release_after,
                 int *reload)
{
    int i;
    for (i = 3; i < argc; i++) {
        Fmu *fmu = *n_fmus ? &fmus[*n_fmus - 1] : NULL;
        if (strcmp(argv[i], "--release-first-after") == 0 && i + 1 < argc) {
            *release_after = strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--reload-first") == 0) {
            *reload = 1;
        } else if (strcmp(argv[i], "-f") == 0 && i + 3 < argc && *n_fmus < MAX_FMUS) {
            fmu = &fmus[(*n_fmus)++];
            fmu->directory = argv[++i];
            fmu->id = argv[++i];
            fmu->token = argv[++i];
        } else if (strcmp(argv[i], "-i") == 0 && fmu && i + 1 < argc
                   && fmu->n_inputs < MAX_VARIABLES) {
            if (!parse_input(argv[++i], &fmu->inputs[fmu->n_inputs++])) return 0;
        } else if (strcmp(argv[i], "-o") == 0 && fmu && i + 1 < argc
                   && fmu->n_outputs < MAX_VARIABLES) {
            if (!parse_output(argv[++i], &fmu->outputs[fmu->n_outputs++])) return 0;
        } else {
            fprintf(stderr, "host3: bad argument '%s'\n", argv[i]);
            return 0;
        }
    }
    return *n_fmus > 0;
}

int main(int argc, char **argv)
{
    static Fmu fmus[MAX_FMUS];
    char labels[MAX_FMUS][12];
    int n_fmus = 0, reload = 0, i;
    long n_steps, release_after = -1, k;
    double h, t = 0.0;

    if (argc < 4 || !parse(argc, argv, fmus, &n_fmus, &release_after, &reload)) {
        fprintf(stderr, "usage: %s N_STEPS STEP_SIZE [--release-first-after K] "
                        "[--reload-first] -f FMU_DIR MODEL_ID TOKEN [-i VR=a[,b,c,d,w]]... "
                        "[-o TYPE:VR]... [-f ...]...\n", argv[0]);
        return 2;
    }
    n_steps = strtol(argv[1], NULL, 10);
    h = strtod(argv[2], NULL);
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) { /* this host must start without Python */
        fprintf(stderr, "host3: the Python C API is already loaded in this process\n");
        return 2;
    }
    for (i = 0; i < n_fmus; i++) {
        snprintf(labels[i], sizeof labels[i], "%d", i);
        if (!start(&fmus[i])) return 2;
        if (!step(&fmus[i], labels[i], t, 0.0)) return 1;
    }
    for (k = 1; k <= n_steps; k++, t += h) {
        for (i = 0; i < n_fmus; i++) {
            if (fmus[i].instance && !step(&fmus[i], labels[i], t, h)) return 1;
        }
        if (k == release_after) stop(&fmus[0]);
    }
    for (i = 0; i < n_fmus; i++) stop(&fmus[i]);
    if (reload && !run_alone(&fmus[0], "R", n_steps, h)) return 1;
    fflush(stdout);
    dl_iterate_phdr(name_libpython, NULL);
    return 0;
}
