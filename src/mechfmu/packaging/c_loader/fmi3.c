/*
 * mechfmu's FMI 3.0 loader: with python_runtime.c and boundary.c, the FMU's
 * binaries/x86_64-linux/<Name>.so when a C compiler was found at build time
 * (src/mechfmu/packaging/build.py), linked with the table of the FMU's variables.
 *
 * At the first fmi3InstantiateCoSimulation it loads the Python runtime and pythonfmu3's
 * library (python_runtime.c says how and in which order) and resolves the FMI 3.0 functions
 * of that library once. When loading fails, the instantiation reports why through the host's
 * logger (status fmi3Fatal) and returns NULL. pythonfmu3's library stays loaded until the
 * process exits (RTLD_NODELETE, see python_runtime.c): unloading it would call Py_Finalize
 * under the other FMUs' objects.
 *
 * Every call then passes the FMI 3.0 boundary before it is forwarded: the co-simulation state
 * machine of the standard (sections 2.3 and 4.2: the allowed calls of each state, and "if any
 * function called in super state FMU State Settable returns fmi3Error, the FMU enters state
 * Terminated"), the value references, types and settability of the variables (boundary.c),
 * the FMU states handed out and the frame of serialised ones. A call that fails a check
 * returns fmi3Error with a log line naming the call, the rule and the state; pythonfmu3 never
 * sees it. Functions of capabilities these FMUs lack (event mode, clocks, derivatives, model
 * exchange, scheduled execution, configuration mode) answer fmi3Error with the reason.
 */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "boundary.h"
#include "fmi3Functions.h"
#include "python_runtime.h"

#define VALUES_GET(T) \
    (fmi3Instance instance, const fmi3ValueReference valueReferences[], \
     size_t nValueReferences, fmi3##T values[], size_t nValues)
#define VALUES_SET(T) \
    (fmi3Instance instance, const fmi3ValueReference valueReferences[], \
     size_t nValueReferences, const fmi3##T values[], size_t nValues)
#define VALUE_TYPES(X) \
    X(Float32, MF_FLOAT32) X(Float64, MF_FLOAT64) X(Int8, MF_INT8) X(UInt8, MF_UINT8) \
    X(Int16, MF_INT16) X(UInt16, MF_UINT16) X(Int32, MF_INT32) X(UInt32, MF_UINT32) \
    X(Int64, MF_INT64) X(UInt64, MF_UINT64) X(Boolean, MF_BOOLEAN) X(String, MF_STRING)

/* The functions of the real library that are forwarded, resolved once (the value functions
 * of types pythonfmu3 lacks may be missing: no variable of this FMU has such a type). */
#define POINTERS(T, tag) fmi3Get##T##TYPE *Get##T; fmi3Set##T##TYPE *Set##T;
static struct {
    fmi3GetVersionTYPE *GetVersion;
    fmi3InstantiateCoSimulationTYPE *InstantiateCoSimulation;
    fmi3FreeInstanceTYPE *FreeInstance;
    fmi3SetDebugLoggingTYPE *SetDebugLogging;
    fmi3EnterInitializationModeTYPE *EnterInitializationMode;
    fmi3ExitInitializationModeTYPE *ExitInitializationMode;
    fmi3TerminateTYPE *Terminate;
    fmi3ResetTYPE *Reset;
    VALUE_TYPES(POINTERS)
    fmi3GetFMUStateTYPE *GetFMUState;
    fmi3SetFMUStateTYPE *SetFMUState;
    fmi3FreeFMUStateTYPE *FreeFMUState;
    fmi3SerializedFMUStateSizeTYPE *SerializedFMUStateSize;
    fmi3SerializeFMUStateTYPE *SerializeFMUState;
    fmi3DeserializeFMUStateTYPE *DeserializeFMUState;
    fmi3DoStepTYPE *DoStep;
} real;
#undef POINTERS

static int load_state; /* 0: not tried, 1: loaded, -1: failed (loader_message says why) */
static int broken;     /* pythonfmu3's library answered fmi3Fatal: nothing is forwarded again */

static int resolve_functions(void *library)
{
#define REQUIRED(name) real.name = (fmi3##name##TYPE *)loader_function(library, "fmi3" #name, 1);
#define OPTIONAL_VALUES(T, tag) \
    real.Get##T = (fmi3Get##T##TYPE *)loader_function(library, "fmi3Get" #T, 0); \
    real.Set##T = (fmi3Set##T##TYPE *)loader_function(library, "fmi3Set" #T, 0);
    REQUIRED(GetVersion)
    REQUIRED(InstantiateCoSimulation)
    REQUIRED(FreeInstance)
    REQUIRED(SetDebugLogging)
    REQUIRED(EnterInitializationMode)
    REQUIRED(ExitInitializationMode)
    REQUIRED(Terminate)
    REQUIRED(Reset)
    VALUE_TYPES(OPTIONAL_VALUES)
    REQUIRED(GetFMUState)
    REQUIRED(SetFMUState)
    REQUIRED(FreeFMUState)
    REQUIRED(SerializedFMUStateSize)
    REQUIRED(SerializeFMUState)
    REQUIRED(DeserializeFMUState)
    REQUIRED(DoStep)
#undef REQUIRED
#undef OPTIONAL_VALUES
    return !loader_missing_functions("pythonfmu3's library");
}

/* Loads once; 1 when every call can be forwarded (see loader_ready). */
static int ready(void)
{
    return loader_ready(&load_state, resolve_functions);
}

/* ---- The state machine (co-simulation without event mode: the other states are never
 * entered) ---- */

enum { INSTANTIATED = 1, INITIALIZATION_MODE = 2, STEP_MODE = 4, TERMINATED = 8 };
#define ANY_STATE (INSTANTIATED | INITIALIZATION_MODE | STEP_MODE | TERMINATED)
#define READABLE (INSTANTIATED | INITIALIZATION_MODE | STEP_MODE | TERMINATED)
#define WRITABLE (INSTANTIATED | INITIALIZATION_MODE | STEP_MODE)

static const char *state_name(int state)
{
    switch (state) {
    case INSTANTIATED: return "Instantiated";
    case INITIALIZATION_MODE: return "Initialization Mode";
    case STEP_MODE: return "Step Mode";
    case TERMINATED: return "Terminated";
    default: return "unknown";
    }
}

static void state_names(int mask, char *out, size_t size)
{
    int state;
    out[0] = '\0';
    if (!mask) snprintf(out, size, "none of this FMU's states");
    for (state = INSTANTIATED; state <= TERMINATED; state <<= 1) {
        if (mask & state) {
            size_t used = strlen(out);
            snprintf(out + used, size - used, "%s%s", used ? ", " : "", state_name(state));
        }
    }
}

struct instance {
    fmi3Instance real;
    int state;
    fmi3Status logged; /* the worst status the model logged during the current call */
    fmi3InstanceEnvironment host_environment;
    fmi3LogMessageCallback host_log;
    double time, stop;
    int stop_defined;
    struct mf_state *states;
};

static const char *category_of(fmi3Status status)
{
    switch (status) {
    case fmi3Warning: return "logStatusWarning";
    case fmi3Discard: return "logStatusDiscard";
    case fmi3Error: return "logStatusError";
    case fmi3Fatal: return "logStatusFatal";
    default: return "logAll";
    }
}

/* One log line of the loader's own, through the host's logger. */
static void say(struct instance *instance, fmi3Status status, const char *format, ...)
{
    char text[2 * MF_WHY_SIZE];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    if (instance->host_log) {
        instance->host_log(instance->host_environment, status, category_of(status), text);
    } else {
        fprintf(stderr, "%s: %s\n", MF_MODEL.identifier, text);
    }
}

/* pythonfmu3's messages on their way to the host: the worst status is noted. */
static void proxy_log(fmi3InstanceEnvironment environment, fmi3Status status,
                      fmi3String category, fmi3String message)
{
    struct instance *instance = environment;
    if (!instance) return;
    if (status > instance->logged) instance->logged = status;
    if (instance->host_log) {
        instance->host_log(instance->host_environment, status, category, message);
    }
}

static void unknown_instance(const char *function, const void *pointer)
{
    fprintf(stderr,
            "%s: %s called with %p, which is no live instance of this FMU (never returned by "
            "fmi3InstantiateCoSimulation, or freed): refused with fmi3Error\n",
            MF_MODEL.identifier, function, pointer);
}

/* The instance when ``function`` may be called now; otherwise NULL, after the log line and
 * the move to Terminated (the standard's answer to any fmi3Error). */
static struct instance *enter(fmi3Instance pointer, const char *function, int allowed)
{
    struct instance *instance = pointer;
    char names[256];
    if (!mf_registered(pointer)) {
        unknown_instance(function, pointer);
        return NULL;
    }
    if (broken) {
        say(instance, fmi3Error,
            "%s refused: pythonfmu3's library returned fmi3Fatal earlier in this process; its "
            "Python state is corrupt and no call is forwarded to it again",
            function);
        instance->state = TERMINATED;
        return NULL;
    }
    if (!(instance->state & allowed)) {
        state_names(allowed, names, sizeof names);
        say(instance, fmi3Error,
            "%s is not allowed in state %s (FMI 3.0 allows it in: %s); refused with "
            "fmi3Error, the instance is now in state Terminated (leave it with fmi3Reset, "
            "fmi3SetFMUState or fmi3FreeInstance)",
            function, state_name(instance->state), names);
        instance->state = TERMINATED;
        return NULL;
    }
    instance->logged = fmi3OK;
    return instance;
}

static fmi3Status refuse(struct instance *instance, const char *why)
{
    say(instance, fmi3Error, "%s; refused with fmi3Error in state %s, the instance is now in "
        "state Terminated", why, state_name(instance->state));
    instance->state = TERMINATED;
    return fmi3Error;
}

static fmi3Status finish(struct instance *instance, fmi3Status status)
{
    if (status == fmi3Fatal) {
        broken = 1;
        instance->state = TERMINATED;
        return status;
    }
    if ((status == fmi3OK || status == fmi3Warning) && instance->logged >= fmi3Error) {
        status = fmi3Error;
    }
    if (status >= fmi3Error) instance->state = TERMINATED;
    return status;
}

static int set_phase(const struct instance *instance)
{
    if (instance->state == INSTANTIATED) return MF_PHASE_INSTANTIATED;
    if (instance->state == INITIALIZATION_MODE) return MF_PHASE_INITIALIZATION;
    return MF_PHASE_STEP;
}

/* ---- Version, instantiation, freeing ---- */

FMI3_Export const char *fmi3GetVersion(void)
{
    return fmi3Version;
}

static void report(fmi3InstanceEnvironment environment, fmi3LogMessageCallback logger,
                   fmi3Status status, const char *text)
{
    if (logger) {
        logger(environment, status, category_of(status), text);
    } else {
        fprintf(stderr, "%s: %s\n", MF_MODEL.identifier, text);
    }
}

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    struct instance *instance;
    char why[MF_WHY_SIZE];
    if (!ready()) {
        report(instanceEnvironment, logMessage, fmi3Fatal, loader_message());
        return NULL;
    }
    if (!instanceName || !*instanceName) {
        report(instanceEnvironment, logMessage, fmi3Error,
               "fmi3InstantiateCoSimulation: instanceName must be a non-empty string");
        return NULL;
    }
    if (!instantiationToken || strcmp(instantiationToken, MF_MODEL.token) != 0) {
        snprintf(why, sizeof why,
                 "fmi3InstantiateCoSimulation: instantiationToken \"%.200s\" is not this FMU's "
                 "\"%s\" (from another FMU, or another build of %s?)",
                 instantiationToken ? instantiationToken : "(NULL)", MF_MODEL.token,
                 MF_MODEL.identifier);
        report(instanceEnvironment, logMessage, fmi3Error, why);
        return NULL;
    }
    if (eventModeUsed) {
        report(instanceEnvironment, logMessage, fmi3Error,
               "fmi3InstantiateCoSimulation: eventModeUsed must be false: this FMU has no event "
               "mode (hasEventMode is false)");
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        report(instanceEnvironment, logMessage, fmi3Error,
               "fmi3InstantiateCoSimulation: no variable of this FMU can be accessed in "
               "intermediate updates (none has intermediateUpdate = true)");
        return NULL;
    }
    if (broken) {
        report(instanceEnvironment, logMessage, fmi3Error,
               "fmi3InstantiateCoSimulation refused: pythonfmu3's library returned fmi3Fatal "
               "earlier in this process");
        return NULL;
    }
    instance = calloc(1, sizeof *instance);
    if (!instance) {
        report(instanceEnvironment, logMessage, fmi3Error, "out of memory");
        return NULL;
    }
    instance->host_environment = instanceEnvironment;
    instance->host_log = logMessage;
    loader_before_interpreter_start();
    instance->real = real.InstantiateCoSimulation(
        instanceName, instantiationToken, resourcePath, visible, loggingOn, eventModeUsed,
        earlyReturnAllowed, requiredIntermediateVariables, nRequiredIntermediateVariables,
        instance, proxy_log, intermediateUpdate);
    loader_after_interpreter_start();
    if (!instance->real) {
        free(instance);
        return NULL;
    }
    instance->state = INSTANTIATED;
    mf_register(instance);
    return instance;
}

/* These FMUs are co-simulation only (their modelDescription.xml says so). */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"

FMI3_Export fmi3Instance fmi3InstantiateModelExchange(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage)
{
    report(instanceEnvironment, logMessage, fmi3Error,
           "this FMU is co-simulation only: use fmi3InstantiateCoSimulation");
    return NULL;
}

FMI3_Export fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    return fmi3InstantiateModelExchange(instanceName, instantiationToken, resourcePath, visible,
                                        loggingOn, instanceEnvironment, logMessage);
}

#pragma GCC diagnostic pop

FMI3_Export void fmi3FreeInstance(fmi3Instance pointer)
{
    struct instance *instance = pointer;
    if (!pointer) return; /* the standard: a NULL instance is ignored */
    if (!mf_registered(pointer)) {
        unknown_instance("fmi3FreeInstance", pointer);
        return;
    }
    mf_unregister(instance);
    while (instance->states) {
        if (!broken) real.FreeFMUState(instance->real, &instance->states->real);
        mf_state_remove(&instance->states, instance->states);
    }
    if (!broken) real.FreeInstance(instance->real);
    free(instance);
}

/* ---- Debug logging, initialisation, termination, reset ---- */

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance pointer, fmi3Boolean loggingOn,
                                           size_t nCategories, const fmi3String categories[])
{
    struct instance *instance = enter(pointer, "fmi3SetDebugLogging", ANY_STATE);
    char why[MF_WHY_SIZE];
    size_t i;
    if (!instance) return fmi3Error;
    if (nCategories > 0 && !categories) {
        return refuse(instance, "fmi3SetDebugLogging: categories is NULL");
    }
    for (i = 0; i < nCategories; i++) {
        if (!mf_known_category(categories[i])) {
            snprintf(why, sizeof why,
                     "fmi3SetDebugLogging: \"%.200s\" is not one of this FMU's log categories",
                     categories[i] ? categories[i] : "(NULL)");
            return refuse(instance, why);
        }
    }
    return finish(instance,
                  real.SetDebugLogging(instance->real, loggingOn, nCategories, categories));
}

FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance pointer,
                                                   fmi3Boolean toleranceDefined,
                                                   fmi3Float64 tolerance, fmi3Float64 startTime,
                                                   fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime)
{
    struct instance *instance = enter(pointer, "fmi3EnterInitializationMode", INSTANTIATED);
    char why[MF_WHY_SIZE];
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!isfinite(startTime) || (stopTimeDefined && !(stopTime >= startTime))) {
        snprintf(why, sizeof why,
                 "fmi3EnterInitializationMode: startTime = %.17g s must be finite and stopTime "
                 "= %.17g s (when defined) not before it",
                 startTime, stopTime);
        return refuse(instance, why);
    }
    status = finish(instance, real.EnterInitializationMode(instance->real, toleranceDefined,
                                                           tolerance, startTime,
                                                           stopTimeDefined, stopTime));
    if (status <= fmi3Warning) {
        instance->state = INITIALIZATION_MODE;
        instance->time = startTime;
        instance->stop = stopTime;
        instance->stop_defined = stopTimeDefined != fmi3False;
    }
    return status;
}

#define TRANSITION(name, from, to) \
    FMI3_Export fmi3Status fmi3##name(fmi3Instance pointer) \
    { \
        struct instance *instance = enter(pointer, "fmi3" #name, from); \
        fmi3Status status; \
        if (!instance) return fmi3Error; \
        status = finish(instance, real.name(instance->real)); \
        if (status <= fmi3Warning) instance->state = to; \
        return status; \
    }

TRANSITION(ExitInitializationMode, INITIALIZATION_MODE, STEP_MODE)
TRANSITION(Terminate, STEP_MODE, TERMINATED)
#undef TRANSITION

FMI3_Export fmi3Status fmi3Reset(fmi3Instance pointer)
{
    struct instance *instance = enter(pointer, "fmi3Reset", ANY_STATE);
    fmi3Status status;
    if (!instance) return fmi3Error;
    status = finish(instance, real.Reset(instance->real));
    if (status <= fmi3Warning) {
        instance->state = INSTANTIATED;
        instance->time = 0.0;
        instance->stop_defined = 0;
    }
    return status;
}

/* ---- Getting and setting variable values ---- */

/* Checks shared by every get and set; 1 when the call may go on. */
static int values_ok(struct instance *instance, const char *function,
                     const fmi3ValueReference references[], size_t nReferences,
                     const void *values, size_t nValues, int type, int phase)
{
    char why[MF_WHY_SIZE + 64];
    char problem[MF_WHY_SIZE];
    if (!mf_check_references(function, references, nReferences, type, phase, problem)) {
        refuse(instance, problem);
        return 0;
    }
    if (nValues != nReferences) {
        snprintf(why, sizeof why,
                 "%s: nValues = %zu for %zu value references: this FMU's variables are all "
                 "scalars, one value each",
                 function, nValues, nReferences);
        refuse(instance, why);
        return 0;
    }
    if (nValues > 0 && !values) {
        snprintf(why, sizeof why, "%s: values is NULL", function);
        refuse(instance, why);
        return 0;
    }
    return 1;
}

/* A set of strings must not hand pythonfmu3 a NULL string. */
static int strings_ok(struct instance *instance, const char *function, const void *values,
                      size_t n, int type)
{
    const fmi3String *strings = values;
    size_t i;
    char why[MF_WHY_SIZE];
    if (type != MF_STRING) return 1;
    for (i = 0; i < n; i++) {
        if (!strings[i]) {
            snprintf(why, sizeof why, "%s: the string at position %zu is NULL", function, i);
            refuse(instance, why);
            return 0;
        }
    }
    return 1;
}

#define VALUE_FUNCTIONS(T, TYPE) \
    FMI3_Export fmi3Status fmi3Get##T VALUES_GET(T) \
    { \
        struct instance *self = enter(instance, "fmi3Get" #T, READABLE); \
        if (!self) return fmi3Error; \
        if (!values_ok(self, "fmi3Get" #T, valueReferences, nValueReferences, values, nValues, \
                       TYPE, -1)) { \
            return fmi3Error; \
        } \
        if (nValueReferences == 0) return fmi3OK; \
        return finish(self, real.Get##T(self->real, valueReferences, nValueReferences, values, \
                                        nValues)); \
    } \
    FMI3_Export fmi3Status fmi3Set##T VALUES_SET(T) \
    { \
        struct instance *self = enter(instance, "fmi3Set" #T, WRITABLE); \
        if (!self) return fmi3Error; \
        if (!values_ok(self, "fmi3Set" #T, valueReferences, nValueReferences, values, nValues, \
                       TYPE, set_phase(self)) \
            || !strings_ok(self, "fmi3Set" #T, values, nValues, TYPE)) { \
            return fmi3Error; \
        } \
        if (nValueReferences == 0) return fmi3OK; \
        return finish(self, real.Set##T(self->real, valueReferences, nValueReferences, values, \
                                        nValues)); \
    }
VALUE_TYPES(VALUE_FUNCTIONS)
#undef VALUE_FUNCTIONS

/* Binary and Clock variables: these FMUs have none, so only empty calls pass. */
FMI3_Export fmi3Status fmi3GetBinary(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, size_t valueSizes[],
                                     fmi3Binary values[], size_t nValues)
{
    struct instance *self = enter(instance, "fmi3GetBinary", READABLE);
    if (!self) return fmi3Error;
    if (!values_ok(self, "fmi3GetBinary", valueReferences, nValueReferences, values, nValues,
                   MF_BINARY, -1)) {
        return fmi3Error;
    }
    return valueSizes || nValues == 0 ? fmi3OK : refuse(self, "fmi3GetBinary: valueSizes is NULL");
}

FMI3_Export fmi3Status fmi3SetBinary(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences, const size_t valueSizes[],
                                     const fmi3Binary values[], size_t nValues)
{
    struct instance *self = enter(instance, "fmi3SetBinary", WRITABLE);
    if (!self) return fmi3Error;
    if (!values_ok(self, "fmi3SetBinary", valueReferences, nValueReferences, values, nValues,
                   MF_BINARY, set_phase(self))) {
        return fmi3Error;
    }
    return valueSizes || nValues == 0 ? fmi3OK : refuse(self, "fmi3SetBinary: valueSizes is NULL");
}

FMI3_Export fmi3Status fmi3GetClock(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, fmi3Clock values[])
{
    struct instance *self = enter(instance, "fmi3GetClock", ANY_STATE);
    if (!self) return fmi3Error;
    return values_ok(self, "fmi3GetClock", valueReferences, nValueReferences, values,
                     nValueReferences, MF_CLOCK, -1)
               ? fmi3OK
               : fmi3Error;
}

FMI3_Export fmi3Status fmi3SetClock(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Clock values[])
{
    struct instance *self = enter(instance, "fmi3SetClock", ANY_STATE);
    if (!self) return fmi3Error;
    return values_ok(self, "fmi3SetClock", valueReferences, nValueReferences, values,
                     nValueReferences, MF_CLOCK, -1)
               ? fmi3OK
               : fmi3Error;
}

/* ---- FMU states ---- */

static struct mf_state *known_state(struct instance *instance, const char *function,
                                    fmi3FMUState state)
{
    char why[MF_WHY_SIZE];
    struct mf_state *record = mf_state_known(instance->states, state, function, why);
    if (!record) refuse(instance, why);
    return record;
}

static int state_slot(struct instance *instance, const char *function, fmi3FMUState *slot,
                      struct mf_state **reuse)
{
    char why[MF_WHY_SIZE];
    if (mf_state_slot(instance->states, slot, function, reuse, why)) return 1;
    refuse(instance, why);
    return 0;
}

static void release_state(void *real_instance, void **state)
{
    real.FreeFMUState((fmi3Instance)real_instance, (fmi3FMUState *)state);
}

static fmi3Status keep_state(struct instance *instance, fmi3FMUState *slot, struct mf_state *reuse,
                             void *real_state, int machine, double time)
{
    if (!mf_state_keep(&instance->states, reuse, slot, real_state, machine, time,
                       release_state, instance->real)) {
        return refuse(instance, "out of memory for an FMU state");
    }
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3GetFMUState(fmi3Instance pointer, fmi3FMUState *FMUState)
{
    struct instance *instance = enter(pointer, "fmi3GetFMUState", ANY_STATE);
    fmi3FMUState real_state = NULL;
    struct mf_state *reuse;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!state_slot(instance, "fmi3GetFMUState", FMUState, &reuse)) return fmi3Error;
    status = finish(instance, real.GetFMUState(instance->real, &real_state));
    if (status > fmi3Warning) return status;
    return keep_state(instance, FMUState, reuse, real_state, instance->state, instance->time);
}

FMI3_Export fmi3Status fmi3SetFMUState(fmi3Instance pointer, fmi3FMUState FMUState)
{
    struct instance *instance = enter(pointer, "fmi3SetFMUState", ANY_STATE);
    struct mf_state *record;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!(record = known_state(instance, "fmi3SetFMUState", FMUState))) return fmi3Error;
    status = finish(instance, real.SetFMUState(instance->real, record->real));
    if (status <= fmi3Warning) {
        instance->state = record->machine;
        instance->time = record->time;
    }
    return status;
}

FMI3_Export fmi3Status fmi3FreeFMUState(fmi3Instance pointer, fmi3FMUState *FMUState)
{
    struct instance *instance = enter(pointer, "fmi3FreeFMUState", ANY_STATE);
    struct mf_state *record;
    if (!instance) return fmi3Error;
    if (!FMUState) return refuse(instance, "fmi3FreeFMUState: FMUState is NULL");
    if (!*FMUState) return fmi3OK; /* nothing to free */
    if (!(record = known_state(instance, "fmi3FreeFMUState", *FMUState))) return fmi3Error;
    real.FreeFMUState(instance->real, &record->real);
    mf_state_remove(&instance->states, record);
    *FMUState = NULL;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializedFMUStateSize(fmi3Instance pointer, fmi3FMUState FMUState,
                                                  size_t *size)
{
    struct instance *instance = enter(pointer, "fmi3SerializedFMUStateSize", ANY_STATE);
    struct mf_state *record;
    size_t payload = 0;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!(record = known_state(instance, "fmi3SerializedFMUStateSize", FMUState))) {
        return fmi3Error;
    }
    if (!size) return refuse(instance, "fmi3SerializedFMUStateSize: size is NULL");
    status = finish(instance,
                    real.SerializedFMUStateSize(instance->real, record->real, &payload));
    if (status > fmi3Warning) return status;
    if (payload == 0) {
        return refuse(instance, "fmi3SerializedFMUStateSize: the model's state holds a value "
                                "the state format cannot write");
    }
    *size = mf_frame_size(payload);
    return status;
}

FMI3_Export fmi3Status fmi3SerializeFMUState(fmi3Instance pointer, fmi3FMUState FMUState,
                                             fmi3Byte serializedState[], size_t size)
{
    struct instance *instance = enter(pointer, "fmi3SerializeFMUState", ANY_STATE);
    struct mf_state *record;
    char why[MF_WHY_SIZE];
    size_t payload = 0;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!(record = known_state(instance, "fmi3SerializeFMUState", FMUState))) return fmi3Error;
    if (!serializedState) {
        return refuse(instance, "fmi3SerializeFMUState: serializedState is NULL");
    }
    status = finish(instance,
                    real.SerializedFMUStateSize(instance->real, record->real, &payload));
    if (status > fmi3Warning) return status;
    if (payload == 0) {
        return refuse(instance, "fmi3SerializeFMUState: the model's state holds a value the "
                                "state format cannot write");
    }
    if (size < mf_frame_size(payload)) {
        snprintf(why, sizeof why,
                 "fmi3SerializeFMUState: size = %zu bytes is less than the %zu the state needs "
                 "(fmi3SerializedFMUStateSize tells it)",
                 size, mf_frame_size(payload));
        return refuse(instance, why);
    }
    status = finish(instance, real.SerializeFMUState(instance->real, record->real,
                                                     serializedState + mf_frame_payload_offset(),
                                                     payload));
    if (status <= fmi3Warning) mf_frame_write(serializedState, payload, record->machine, record->time);
    return status;
}

FMI3_Export fmi3Status fmi3DeserializeFMUState(fmi3Instance pointer,
                                               const fmi3Byte serializedState[], size_t size,
                                               fmi3FMUState *FMUState)
{
    struct instance *instance = enter(pointer, "fmi3DeserializeFMUState", ANY_STATE);
    const unsigned char *payload;
    char why[MF_WHY_SIZE + 32], problem[MF_WHY_SIZE];
    fmi3FMUState real_state = NULL;
    struct mf_state *reuse;
    size_t payload_size;
    double time;
    int machine;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!mf_frame_read(serializedState, size, &payload, &payload_size, &machine, &time,
                       problem)) {
        snprintf(why, sizeof why, "fmi3DeserializeFMUState: %s", problem);
        return refuse(instance, why);
    }
    if (machine != INSTANTIATED && machine != INITIALIZATION_MODE && machine != STEP_MODE
        && machine != TERMINATED) {
        return refuse(instance, "fmi3DeserializeFMUState: the state names an unknown "
                                "state-machine state");
    }
    if (!state_slot(instance, "fmi3DeserializeFMUState", FMUState, &reuse)) return fmi3Error;
    status = finish(instance, real.DeserializeFMUState(instance->real, payload, payload_size,
                                                       &real_state));
    if (status > fmi3Warning) return status;
    return keep_state(instance, FMUState, reuse, real_state, machine, time);
}

/* ---- Co-simulation ---- */

FMI3_Export fmi3Status fmi3DoStep(fmi3Instance pointer, fmi3Float64 currentCommunicationPoint,
                                  fmi3Float64 communicationStepSize,
                                  fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                  fmi3Boolean *eventHandlingNeeded,
                                  fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                                  fmi3Float64 *lastSuccessfulTime)
{
    struct instance *instance = enter(pointer, "fmi3DoStep", STEP_MODE);
    char why[MF_WHY_SIZE];
    double end = currentCommunicationPoint + communicationStepSize;
    fmi3Status status;
    if (!instance) return fmi3Error;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime) {
        return refuse(instance, "fmi3DoStep: eventHandlingNeeded, terminateSimulation, "
                                "earlyReturn and lastSuccessfulTime must not be NULL");
    }
    if (!isfinite(currentCommunicationPoint) || !isfinite(communicationStepSize)
        || !(communicationStepSize > 0.0)) {
        snprintf(why, sizeof why,
                 "fmi3DoStep: communicationStepSize = %.17g s at currentCommunicationPoint = "
                 "%.17g s: the step size must be > 0.0 and both finite (FMI 3.0 section 4.2.1)",
                 communicationStepSize, currentCommunicationPoint);
        return refuse(instance, why);
    }
    if (instance->stop_defined && mf_beyond(end, instance->stop)) {
        snprintf(why, sizeof why,
                 "fmi3DoStep: the step from t = %.17g s by %.17g s ends beyond stopTime = %.17g "
                 "s given to fmi3EnterInitializationMode",
                 currentCommunicationPoint, communicationStepSize, instance->stop);
        return refuse(instance, why);
    }
    status = finish(instance, real.DoStep(instance->real, currentCommunicationPoint,
                                          communicationStepSize,
                                          noSetFMUStatePriorToCurrentPoint, eventHandlingNeeded,
                                          terminateSimulation, earlyReturn,
                                          lastSuccessfulTime));
    if (status <= fmi3Warning) {
        instance->time = end;
    } else if (status == fmi3Discard) {
        *lastSuccessfulTime = instance->time; /* nothing of the step was taken */
        *earlyReturn = fmi3False;
        *eventHandlingNeeded = fmi3False;
        *terminateSimulation = fmi3False;
    }
    return status;
}

/* ---- Capabilities these FMUs do not have ---- */

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"

#define NOT_PROVIDED(name, params, allowed, why) \
    FMI3_Export fmi3Status fmi3##name params \
    { \
        struct instance *self = enter(instance, "fmi3" #name, allowed); \
        if (!self) return fmi3Error; \
        return refuse(self, "fmi3" #name ": " why); \
    }
#define REFERENCES \
    fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences
#define NO_EVENT_MODE "this FMU has no event mode (hasEventMode is false)"
#define NO_CLOCKS "this FMU has no clocks"
#define ME_ONLY "a model-exchange function; this FMU is co-simulation only"

NOT_PROVIDED(EnterEventMode, (fmi3Instance instance), STEP_MODE, NO_EVENT_MODE)
NOT_PROVIDED(EnterStepMode, (fmi3Instance instance), 0, NO_EVENT_MODE)
NOT_PROVIDED(EvaluateDiscreteStates, (fmi3Instance instance), 0, NO_EVENT_MODE)
NOT_PROVIDED(UpdateDiscreteStates,
             (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
              fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
              fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
              fmi3Float64 *nextEventTime),
             0, NO_EVENT_MODE)
NOT_PROVIDED(GetNumberOfVariableDependencies,
             (fmi3Instance instance, fmi3ValueReference valueReference, size_t *nDependencies),
             ANY_STATE,
             "this FMU gives its dependencies in modelDescription.xml only "
             "(providesPerElementDependencies is false)")
NOT_PROVIDED(GetVariableDependencies,
             (fmi3Instance instance, fmi3ValueReference dependent,
              size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
              size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
              size_t nDependencies),
             ANY_STATE,
             "this FMU gives its dependencies in modelDescription.xml only "
             "(providesPerElementDependencies is false)")
NOT_PROVIDED(GetDirectionalDerivative,
             (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
              const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
              size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity),
             INITIALIZATION_MODE | STEP_MODE | TERMINATED,
             "this FMU provides no directional derivatives "
             "(providesDirectionalDerivatives is false)")
NOT_PROVIDED(GetAdjointDerivative,
             (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
              const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
              size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity),
             INITIALIZATION_MODE | STEP_MODE | TERMINATED,
             "this FMU provides no adjoint derivatives (providesAdjointDerivatives is false)")
NOT_PROVIDED(EnterConfigurationMode, (fmi3Instance instance), INSTANTIATED | STEP_MODE,
             "this FMU has no structural parameters to configure")
NOT_PROVIDED(ExitConfigurationMode, (fmi3Instance instance), 0,
             "this FMU has no configuration mode")
NOT_PROVIDED(GetIntervalDecimal,
             (REFERENCES, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]),
             ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(GetIntervalFraction,
             (REFERENCES, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
              fmi3IntervalQualifier qualifiers[]),
             ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(GetShiftDecimal, (REFERENCES, fmi3Float64 shifts[]), ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(GetShiftFraction, (REFERENCES, fmi3UInt64 counters[], fmi3UInt64 resolutions[]),
             ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(SetIntervalDecimal, (REFERENCES, const fmi3Float64 intervals[]), ANY_STATE,
             NO_CLOCKS)
NOT_PROVIDED(SetIntervalFraction,
             (REFERENCES, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
             ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(SetShiftDecimal, (REFERENCES, const fmi3Float64 shifts[]), ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(SetShiftFraction,
             (REFERENCES, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
             ANY_STATE, NO_CLOCKS)
NOT_PROVIDED(GetOutputDerivatives,
             (REFERENCES, const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues),
             STEP_MODE | TERMINATED,
             "this FMU provides no output derivatives (maxOutputDerivativeOrder is 0)")
NOT_PROVIDED(ActivateModelPartition,
             (fmi3Instance instance, fmi3ValueReference clockReference,
              fmi3Float64 activationTime),
             0, "a scheduled-execution function; this FMU is co-simulation only")
NOT_PROVIDED(EnterContinuousTimeMode, (fmi3Instance instance), 0, ME_ONLY)
NOT_PROVIDED(CompletedIntegratorStep,
             (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
              fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation),
             0, ME_ONLY)
NOT_PROVIDED(SetTime, (fmi3Instance instance, fmi3Float64 time), 0, ME_ONLY)
NOT_PROVIDED(SetContinuousStates,
             (fmi3Instance instance, const fmi3Float64 continuousStates[],
              size_t nContinuousStates),
             0, ME_ONLY)
NOT_PROVIDED(GetContinuousStateDerivatives,
             (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates), 0,
             ME_ONLY)
NOT_PROVIDED(GetEventIndicators,
             (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators),
             0, ME_ONLY)
NOT_PROVIDED(GetContinuousStates,
             (fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates),
             0, ME_ONLY)
NOT_PROVIDED(GetNominalsOfContinuousStates,
             (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates), 0,
             ME_ONLY)
NOT_PROVIDED(GetNumberOfEventIndicators, (fmi3Instance instance, size_t *nEventIndicators), 0,
             ME_ONLY)
NOT_PROVIDED(GetNumberOfContinuousStates, (fmi3Instance instance, size_t *nContinuousStates), 0,
             ME_ONLY)

#pragma GCC diagnostic pop
