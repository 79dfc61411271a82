/*
 * mechfmu's FMI 2.0 loader: the FMU's binaries/linux64/<Name>.so when a C compiler was found
 * at build time (see src/mechfmu/build.py).
 *
 * pythonfmu's Linux library leaves the Python C API unresolved (it expects to be loaded into a
 * process that already has libpython's symbols in its global scope, such as a Python host).
 * A C or C++ host that dlopens it fails with "undefined symbol: _Py_NoneStruct". This loader
 * has no such dependency. At the first fmi2Instantiate (or fmi2GetVersion/GetTypesPlatform)
 * it
 *
 *   1. uses the host's Python when the process already has the C API in its global scope
 *      (dlsym(RTLD_DEFAULT, "Py_IsInitialized") != NULL, e.g. fmpy in a Python process);
 *      otherwise dlopens libpython (RTLD_NOW | RTLD_GLOBAL) from, in order: the file named by
 *      $MECHFMU_LIBPYTHON, $PYTHONHOME/lib/<soname>, the build machine's LIBDIR/<soname>,
 *      <soname> and libpython<major.minor>.so through the dynamic linker's search
 *      (LD_LIBRARY_PATH, ld.so.cache, /lib, /usr/lib);
 *   2. dlopens pythonfmu's library, <Name>.pythonfmu.so next to this file (RTLD_NOW |
 *      RTLD_LOCAL), and resolves every FMI 2.0 function of it once;
 *   3. when the interpreter is not running yet, points it to the standard library of that
 *      libpython (Py_SetPythonHome; see set_python_home), unless PYTHONHOME is set;
 *
 * and then forwards every FMI 2.0 call to it unchanged. When loading fails, fmi2Instantiate
 * reports why through the host's logger (status fmi2Fatal) and returns NULL.
 *
 * When the host unloads this library, pythonfmu's library is closed too (as if the host had
 * loaded it directly, as before); libpython, once loaded here, stays: an interpreter must not
 * be unloaded under live objects.
 *
 * Standard C and <dlfcn.h> only. Build-time definitions (strings):
 *   PYTHON_SONAME   the libpython the FMU was built with, e.g. "libpython3.11.so.1.0"
 *   PYTHON_LIBDIR   the directory it was in on the build machine
 *   PYTHON_VERSION  its major.minor, e.g. "3.11"
 */

#define _GNU_SOURCE /* RTLD_DEFAULT, dladdr */
#include <dlfcn.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef PYTHON_SONAME
#error "define PYTHON_SONAME, e.g. -DPYTHON_SONAME=\"libpython3.11.so.1.0\""
#endif
#ifndef PYTHON_LIBDIR
#define PYTHON_LIBDIR ""
#endif
#ifndef PYTHON_VERSION
#error "define PYTHON_VERSION, e.g. -DPYTHON_VERSION=\"3.11\""
#endif

#define INNER_SUFFIX ".pythonfmu.so"
#define MAX_CANDIDATES 6
#define MESSAGE_SIZE 4096

/* Every function of the real library, resolved once. */
static struct {
    fmi2GetTypesPlatformTYPE *GetTypesPlatform;
    fmi2GetVersionTYPE *GetVersion;
    fmi2SetDebugLoggingTYPE *SetDebugLogging;
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2GetRealTYPE *GetReal;
    fmi2GetIntegerTYPE *GetInteger;
    fmi2GetBooleanTYPE *GetBoolean;
    fmi2GetStringTYPE *GetString;
    fmi2SetRealTYPE *SetReal;
    fmi2SetIntegerTYPE *SetInteger;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2SetStringTYPE *SetString;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2GetDirectionalDerivativeTYPE *GetDirectionalDerivative;
    fmi2SetRealInputDerivativesTYPE *SetRealInputDerivatives;
    fmi2GetRealOutputDerivativesTYPE *GetRealOutputDerivatives;
    fmi2DoStepTYPE *DoStep;
    fmi2CancelStepTYPE *CancelStep;
    fmi2GetStatusTYPE *GetStatus;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2GetIntegerStatusTYPE *GetIntegerStatus;
    fmi2GetBooleanStatusTYPE *GetBooleanStatus;
    fmi2GetStringStatusTYPE *GetStringStatus;
} real;

static void *real_library;        /* pythonfmu's library, once loaded */
static int load_state;            /* 0: not tried, 1: loaded, -1: failed (message says why) */
static char message[MESSAGE_SIZE]; /* why loading failed */
static char own_path[PATH_MAX];    /* this library's absolute path, taken when it is loaded */

static void append(const char *format, ...)
{
    size_t used = strlen(message);
    va_list args;
    if (used + 1 >= sizeof message) return;
    va_start(args, format);
    vsnprintf(message + used, sizeof message - used, format, args);
    va_end(args);
}

/* The path of this file, made absolute while the host's working directory is still the one
 * it passed to dlopen. */
__attribute__((constructor)) static void remember_own_path(void)
{
    Dl_info info;
    if (dladdr((void *)&remember_own_path, &info) && info.dli_fname) {
        if (!realpath(info.dli_fname, own_path)) {
            strncpy(own_path, info.dli_fname, sizeof own_path - 1);
        }
    }
}

/* The host unloads this FMU (dlclose): release pythonfmu's library with it. At process exit
 * the dynamic linker keeps every library mapped until all destructors have run. */
__attribute__((destructor)) static void release_real_library(void)
{
    if (real_library) dlclose(real_library);
    real_library = NULL;
}

static int load_python(void)
{
    const char *candidates[MAX_CANDIDATES];
    char from_home[PATH_MAX], from_libdir[PATH_MAX];
    const char *env;
    int count = 0, i;

    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized") != NULL) {
        return 1; /* the host has the Python C API loaded globally: use it, load no other */
    }
    env = getenv("MECHFMU_LIBPYTHON");
    if (env && *env) candidates[count++] = env;
    env = getenv("PYTHONHOME");
    if (env && *env) {
        snprintf(from_home, sizeof from_home, "%s/lib/%s", env, PYTHON_SONAME);
        candidates[count++] = from_home;
    }
    if (PYTHON_LIBDIR[0]) {
        snprintf(from_libdir, sizeof from_libdir, "%s/%s", PYTHON_LIBDIR, PYTHON_SONAME);
        candidates[count++] = from_libdir;
    }
    candidates[count++] = PYTHON_SONAME;
    candidates[count++] = "libpython" PYTHON_VERSION ".so";

    append("no Python " PYTHON_VERSION " runtime found: this FMU runs its model in Python and "
           "needs the shared library " PYTHON_SONAME "; tried");
    for (i = 0; i < count; i++) {
        const char *error;
        if (dlopen(candidates[i], RTLD_NOW | RTLD_GLOBAL) != NULL) {
            message[0] = '\0';
            return 1;
        }
        error = dlerror();
        append("%s %s (%s)", i ? ";" : "", candidates[i], error ? error : "unknown error");
    }
    append(". Install Python " PYTHON_VERSION " with its shared library, or set "
           "MECHFMU_LIBPYTHON to the path of " PYTHON_SONAME ".");
    return 0;
}

/* When the interpreter is not running yet (pythonfmu will start it), tell it where its own
 * standard library is: the prefix above the libpython that holds the C API (the first of its
 * parent directories with lib/python<major.minor>/os.py). Otherwise an embedded interpreter
 * looks for "python3" on PATH and may take the standard library of another Python (found:
 * /usr/lib/python3.11 of the system's 3.11.2 for pyenv's 3.11.7, "No module named 'math'").
 * A PYTHONHOME set by the user is left to decide. */
static void set_python_home(void)
{
    typedef int is_initialized_t(void);
    typedef void *decode_locale_t(const char *, size_t *);
    typedef void set_home_t(const void *);
    is_initialized_t *is_initialized = (is_initialized_t *)dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    decode_locale_t *decode_locale = (decode_locale_t *)dlsym(RTLD_DEFAULT, "Py_DecodeLocale");
    set_home_t *set_home = (set_home_t *)dlsym(RTLD_DEFAULT, "Py_SetPythonHome");
    static void *home; /* kept for the interpreter's lifetime */
    char prefix[PATH_MAX], landmark[PATH_MAX + 32];
    Dl_info info;
    int level;

    if (!is_initialized || is_initialized() || !decode_locale || !set_home || home) return;
    if (getenv("PYTHONHOME") && *getenv("PYTHONHOME")) return;
    if (!dladdr((void *)is_initialized, &info) || !info.dli_fname
        || !realpath(info.dli_fname, prefix)) {
        return;
    }
    for (level = 0; level < 4; level++) {
        char *slash = strrchr(prefix, '/');
        FILE *file;
        if (!slash || slash == prefix) return;
        *slash = '\0';
        snprintf(landmark, sizeof landmark, "%s/lib/python" PYTHON_VERSION "/os.py", prefix);
        file = fopen(landmark, "r");
        if (file) {
            fclose(file);
            home = decode_locale(prefix, NULL);
            if (home) set_home(home);
            return;
        }
    }
}

static void *symbol(void *library, const char *name, int required)
{
    void *address = dlsym(library, name);
    if (!address && required) {
        const char *error = dlerror();
        append("%s%s", message[0] ? "; " : "", error ? error : name);
    }
    return address;
}

static int load_real_library(void)
{
    char inner[PATH_MAX];
    size_t length = strlen(own_path);
    void *library;

    if (length < 3 || strcmp(own_path + length - 3, ".so") != 0
        || length - 3 + sizeof INNER_SUFFIX > sizeof inner) {
        append("cannot tell the path of pythonfmu's library from this loader's path '%s'",
               own_path);
        return 0;
    }
    memcpy(inner, own_path, length - 3);
    strcpy(inner + length - 3, INNER_SUFFIX);
    library = dlopen(inner, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        const char *error = dlerror();
        append("cannot load pythonfmu's library: %s", error ? error : inner);
        return 0;
    }
#define REQUIRED(name) real.name = (fmi2##name##TYPE *)symbol(library, "fmi2" #name, 1)
#define OPTIONAL(name) real.name = (fmi2##name##TYPE *)symbol(library, "fmi2" #name, 0)
    REQUIRED(GetTypesPlatform);
    REQUIRED(GetVersion);
    REQUIRED(Instantiate);
    REQUIRED(FreeInstance);
    OPTIONAL(SetDebugLogging);
    OPTIONAL(SetupExperiment);
    OPTIONAL(EnterInitializationMode);
    OPTIONAL(ExitInitializationMode);
    OPTIONAL(Terminate);
    OPTIONAL(Reset);
    OPTIONAL(GetReal);
    OPTIONAL(GetInteger);
    OPTIONAL(GetBoolean);
    OPTIONAL(GetString);
    OPTIONAL(SetReal);
    OPTIONAL(SetInteger);
    OPTIONAL(SetBoolean);
    OPTIONAL(SetString);
    OPTIONAL(GetFMUstate);
    OPTIONAL(SetFMUstate);
    OPTIONAL(FreeFMUstate);
    OPTIONAL(SerializedFMUstateSize);
    OPTIONAL(SerializeFMUstate);
    OPTIONAL(DeSerializeFMUstate);
    OPTIONAL(GetDirectionalDerivative);
    OPTIONAL(SetRealInputDerivatives);
    OPTIONAL(GetRealOutputDerivatives);
    OPTIONAL(DoStep);
    OPTIONAL(CancelStep);
    OPTIONAL(GetStatus);
    OPTIONAL(GetRealStatus);
    OPTIONAL(GetIntegerStatus);
    OPTIONAL(GetBooleanStatus);
    OPTIONAL(GetStringStatus);
#undef REQUIRED
#undef OPTIONAL
    real_library = library;
    if (message[0]) {
        char detail[MESSAGE_SIZE];
        memcpy(detail, message, sizeof detail);
        message[0] = '\0';
        append("pythonfmu's library %s lacks FMI functions: %s", inner, detail);
        return 0;
    }
    return 1;
}

/* Loads once; 1 when every call can be forwarded. Not thread-safe: the host's first
 * fmi2Instantiate must not race another call into this FMU (hosts instantiate in turn). */
static int ready(void)
{
    if (load_state == 0) {
        message[0] = '\0';
        dlerror();
        load_state = (load_python() && load_real_library()) ? 1 : -1;
        if (load_state == 1) set_python_home();
    }
    return load_state == 1;
}

/* ---- Common functions ---- */

FMI2_Export const char *fmi2GetTypesPlatform(void)
{
    return ready() ? real.GetTypesPlatform() : fmi2TypesPlatform;
}

FMI2_Export const char *fmi2GetVersion(void)
{
    return ready() ? real.GetVersion() : fmi2Version;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    if (!ready()) {
        if (functions && functions->logger) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Fatal,
                              "logStatusFatal", "%s", message);
        } else {
            fprintf(stderr, "%s: %s\n", instanceName ? instanceName : "FMU", message);
        }
        return NULL;
    }
    return real.Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, functions,
                            visible, loggingOn);
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    if (c && load_state == 1) real.FreeInstance(c);
}

/* Every other function: forwarded when loaded and present, fmi2Error otherwise (there can be
 * no instance then: fmi2Instantiate returned NULL). */
#define FORWARD(name, params, args) \
    FMI2_Export fmi2Status fmi2##name params \
    { \
        if (load_state != 1 || !real.name) return fmi2Error; \
        return real.name args; \
    }

FORWARD(SetDebugLogging,
        (fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
         const fmi2String categories[]),
        (c, loggingOn, nCategories, categories))
FORWARD(SetupExperiment,
        (fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
         fmi2Boolean stopTimeDefined, fmi2Real stopTime),
        (c, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime))
FORWARD(EnterInitializationMode, (fmi2Component c), (c))
FORWARD(ExitInitializationMode, (fmi2Component c), (c))
FORWARD(Terminate, (fmi2Component c), (c))
FORWARD(Reset, (fmi2Component c), (c))
FORWARD(GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]),
        (c, vr, nvr, value))
FORWARD(GetInteger,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]),
        (c, vr, nvr, value))
FORWARD(GetBoolean,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]),
        (c, vr, nvr, value))
FORWARD(GetString,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]),
        (c, vr, nvr, value))
FORWARD(SetReal,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]),
        (c, vr, nvr, value))
FORWARD(SetInteger,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]),
        (c, vr, nvr, value))
FORWARD(SetBoolean,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]),
        (c, vr, nvr, value))
FORWARD(SetString,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]),
        (c, vr, nvr, value))
FORWARD(GetFMUstate, (fmi2Component c, fmi2FMUstate *FMUstate), (c, FMUstate))
FORWARD(SetFMUstate, (fmi2Component c, fmi2FMUstate FMUstate), (c, FMUstate))
FORWARD(FreeFMUstate, (fmi2Component c, fmi2FMUstate *FMUstate), (c, FMUstate))
FORWARD(SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate FMUstate, size_t *size),
        (c, FMUstate, size))
FORWARD(SerializeFMUstate,
        (fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size),
        (c, FMUstate, serializedState, size))
FORWARD(DeSerializeFMUstate,
        (fmi2Component c, const fmi2Byte serializedState[], size_t size, fmi2FMUstate *FMUstate),
        (c, serializedState, size, FMUstate))
FORWARD(GetDirectionalDerivative,
        (fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
         const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
         fmi2Real dvUnknown[]),
        (c, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown, dvUnknown))

/* ---- Co-simulation ---- */

FORWARD(SetRealInputDerivatives,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
         const fmi2Real value[]),
        (c, vr, nvr, order, value))
FORWARD(GetRealOutputDerivatives,
        (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
         fmi2Real value[]),
        (c, vr, nvr, order, value))
FORWARD(DoStep,
        (fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
         fmi2Boolean noSetFMUStatePriorToCurrentPoint),
        (c, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint))
FORWARD(CancelStep, (fmi2Component c), (c))
FORWARD(GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value), (c, s, value))
FORWARD(GetRealStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Real *value),
        (c, s, value))
FORWARD(GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value),
        (c, s, value))
FORWARD(GetBooleanStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value),
        (c, s, value))
FORWARD(GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value),
        (c, s, value))

/* ---- Model exchange: these FMUs are co-simulation only ---- */

#pragma GCC diagnostic ignored "-Wunused-parameter"

#define NOT_MODEL_EXCHANGE(name, params) \
    FMI2_Export fmi2Status fmi2##name params \
    { \
        return fmi2Error; \
    }

NOT_MODEL_EXCHANGE(EnterEventMode, (fmi2Component c))
NOT_MODEL_EXCHANGE(NewDiscreteStates, (fmi2Component c, fmi2EventInfo *fmi2eventInfo))
NOT_MODEL_EXCHANGE(EnterContinuousTimeMode, (fmi2Component c))
NOT_MODEL_EXCHANGE(CompletedIntegratorStep,
                   (fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                    fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation))
NOT_MODEL_EXCHANGE(SetTime, (fmi2Component c, fmi2Real time))
NOT_MODEL_EXCHANGE(SetContinuousStates, (fmi2Component c, const fmi2Real x[], size_t nx))
NOT_MODEL_EXCHANGE(GetDerivatives, (fmi2Component c, fmi2Real derivatives[], size_t nx))
NOT_MODEL_EXCHANGE(GetEventIndicators, (fmi2Component c, fmi2Real eventIndicators[], size_t ni))
NOT_MODEL_EXCHANGE(GetContinuousStates, (fmi2Component c, fmi2Real x[], size_t nx))
NOT_MODEL_EXCHANGE(GetNominalsOfContinuousStates,
                   (fmi2Component c, fmi2Real x_nominal[], size_t nx))
