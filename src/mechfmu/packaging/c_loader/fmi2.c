/*
 * mechfmu's FMI 2.0 loader: with python_runtime.c and boundary.c, the FMU's
 * binaries/linux64/<Name>.so when a C compiler was found at build time
 * (src/mechfmu/packaging/build.py), linked with the table of the FMU's variables.
 *
 * At the first fmi2Instantiate (or fmi2GetVersion/GetTypesPlatform) it loads the Python
 * runtime and pythonfmu's library (python_runtime.c says how and in which order) and resolves
 * every FMI 2.0 function of that library once. When loading fails, fmi2Instantiate reports why
 * through the host's logger (status fmi2Fatal) and returns NULL.
 *
 * Every call then passes the FMI 2.0 boundary before it is forwarded: the co-simulation state
 * machine of the standard (section 4.2.4, the table of allowed calls per state), the value
 * references, types and settability of the variables (boundary.c), the FMU states handed out
 * and the frame of serialised ones. A call that fails a check returns fmi2Error with a log line
 * naming the call, the rule and the state, and the instance enters the standard's error state
 * (left by fmi2Reset, fmi2SetFMUstate or fmi2FreeInstance); pythonfmu never sees it. An error
 * the model logs during a call it answers with fmi2OK (pythonfmu cannot return fmi2Error from
 * Python) becomes that call's fmi2Error. docs/other-tools/fmi_boundary.md has the details.
 */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "boundary.h"
#include "fmi2Functions.h"
#include "python_runtime.h"

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
    fmi2DoStepTYPE *DoStep;
} real;

static int load_state; /* 0: not tried, 1: loaded, -1: failed (loader_message says why) */
static int broken;     /* pythonfmu's library answered fmi2Fatal: nothing is forwarded again */

static int resolve_functions(void *library)
{
#define REQUIRED(name) real.name = (fmi2##name##TYPE *)loader_function(library, "fmi2" #name, 1)
    REQUIRED(GetTypesPlatform);
    REQUIRED(GetVersion);
    REQUIRED(Instantiate);
    REQUIRED(FreeInstance);
    REQUIRED(SetDebugLogging);
    REQUIRED(SetupExperiment);
    REQUIRED(EnterInitializationMode);
    REQUIRED(ExitInitializationMode);
    REQUIRED(Terminate);
    REQUIRED(Reset);
    REQUIRED(GetReal);
    REQUIRED(GetInteger);
    REQUIRED(GetBoolean);
    REQUIRED(GetString);
    REQUIRED(SetReal);
    REQUIRED(SetInteger);
    REQUIRED(SetBoolean);
    REQUIRED(SetString);
    REQUIRED(GetFMUstate);
    REQUIRED(SetFMUstate);
    REQUIRED(FreeFMUstate);
    REQUIRED(SerializedFMUstateSize);
    REQUIRED(SerializeFMUstate);
    REQUIRED(DeSerializeFMUstate);
    REQUIRED(DoStep);
#undef REQUIRED
    return !loader_missing_functions("pythonfmu's library");
}

/* Loads once; 1 when every call can be forwarded (see loader_ready). */
static int ready(void)
{
    return loader_ready(&load_state, resolve_functions);
}

/* ---- The state machine (FMI 2.0 section 4.2.4; stepInProgress and stepCanceled are never
 * entered: these FMUs never return fmi2Pending) ---- */

enum {
    INSTANTIATED = 1,
    INITIALIZATION_MODE = 2,
    STEP_COMPLETE = 4,
    TERMINATED = 8,
    ERROR_STATE = 16
};
#define ANY_STATE (INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE | TERMINATED | ERROR_STATE)
#define READABLE (INITIALIZATION_MODE | STEP_COMPLETE | TERMINATED | ERROR_STATE)
#define WRITABLE (INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE)
#define STATUS_READABLE (STEP_COMPLETE | TERMINATED)

static const char *state_name(int state)
{
    switch (state) {
    case INSTANTIATED: return "instantiated";
    case INITIALIZATION_MODE: return "Initialization Mode";
    case STEP_COMPLETE: return "stepComplete";
    case TERMINATED: return "terminated";
    case ERROR_STATE: return "error";
    default: return "unknown";
    }
}

static void state_names(int mask, char *out, size_t size)
{
    int state;
    out[0] = '\0';
    if (!mask) snprintf(out, size, "none of this FMU's states");
    for (state = INSTANTIATED; state <= ERROR_STATE; state <<= 1) {
        if (mask & state) {
            size_t used = strlen(out);
            snprintf(out + used, size - used, "%s%s", used ? ", " : "", state_name(state));
        }
    }
}

struct instance {
    fmi2Component real;
    int state;
    fmi2Status logged; /* the worst status the model logged during the current call */
    fmi2CallbackFunctions host;  /* the host's callbacks */
    fmi2CallbackFunctions proxy; /* given to pythonfmu: its messages pass proxy_logger */
    char *name;
    double time, stop;
    int stop_defined;
    struct mf_state *states;
};

/* One log line of the loader's own, through the host's logger (as its message: "%s"). */
static void say(struct instance *instance, fmi2Status status, const char *format, ...)
{
    char text[2 * MF_WHY_SIZE];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    if (instance->host.logger) {
        instance->host.logger(instance->host.componentEnvironment, instance->name, status,
                              status >= fmi2Error   ? "logStatusError"
                              : status == fmi2Discard ? "logStatusDiscard"
                                                      : "logStatusWarning",
                              "%s", text);
    } else {
        fprintf(stderr, "%s: %s\n", instance->name, text);
    }
}

/* pythonfmu's messages on their way to the host. pythonfmu passes each message's text as
 * the format string, with no arguments: a '%' in it (a parameter value such as "50%s") made
 * the host's logger read arguments that are not there (a segmentation fault in fmpy). Here it
 * is passed on as text. */
static void proxy_logger(fmi2ComponentEnvironment environment, fmi2String name,
                         fmi2Status status, fmi2String category, fmi2String message, ...)
{
    struct instance *instance = environment;
    if (!instance) return;
    if (status > instance->logged) instance->logged = status;
    if (instance->host.logger) {
        instance->host.logger(instance->host.componentEnvironment, name, status, category, "%s",
                              message ? message : "");
    }
}

static void unknown_instance(const char *function, const void *component)
{
    fprintf(stderr,
            "%s: %s called with %p, which is no live instance of this FMU (never returned by "
            "fmi2Instantiate, or freed): refused with fmi2Error\n",
            MF_MODEL.identifier, function, component);
}

/* The instance behind ``component`` when ``function`` may be called now; otherwise NULL, after
 * the log line (and the error state, as the standard has it for any fmi2Error). */
static struct instance *enter(fmi2Component component, const char *function, int allowed)
{
    struct instance *instance = component;
    char names[256];
    if (!mf_registered(component)) {
        unknown_instance(function, component);
        return NULL;
    }
    if (broken) {
        say(instance, fmi2Error,
            "%s refused: pythonfmu's library returned fmi2Fatal earlier in this process; its "
            "Python state is corrupt and no call is forwarded to it again",
            function);
        instance->state = ERROR_STATE;
        return NULL;
    }
    if (!(instance->state & allowed)) {
        state_names(allowed, names, sizeof names);
        say(instance, fmi2Error,
            "%s is not allowed in state %s (FMI 2.0 allows it in: %s); refused with "
            "fmi2Error, the instance is now in state error (leave it with fmi2Reset, "
            "fmi2SetFMUstate or fmi2FreeInstance)",
            function, state_name(instance->state), names);
        instance->state = ERROR_STATE;
        return NULL;
    }
    instance->logged = fmi2OK;
    return instance;
}

/* A check failed: the log line (``why`` names the call and the rule), the error state. */
static fmi2Status refuse(struct instance *instance, const char *why)
{
    say(instance, fmi2Error, "%s; refused with fmi2Error in state %s, the instance is now in "
        "state error", why, state_name(instance->state));
    instance->state = ERROR_STATE;
    return fmi2Error;
}

/* What a forwarded call returns: an error the model logged makes an OK call an error; an
 * error enters the error state; a fatal status stops all forwarding. */
static fmi2Status finish(struct instance *instance, fmi2Status status)
{
    if (status == fmi2Fatal) {
        broken = 1;
        instance->state = ERROR_STATE;
        return status;
    }
    if ((status == fmi2OK || status == fmi2Warning) && instance->logged >= fmi2Error) {
        status = fmi2Error;
    }
    if (status >= fmi2Error) instance->state = ERROR_STATE;
    return status;
}

/* The phase whose rules a set follows in the instance's state. */
static int set_phase(const struct instance *instance)
{
    if (instance->state == INSTANTIATED) return MF_PHASE_INSTANTIATED;
    if (instance->state == INITIALIZATION_MODE) return MF_PHASE_INITIALIZATION;
    return MF_PHASE_STEP;
}

/* ---- Common functions ---- */

FMI2_Export const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

FMI2_Export const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

static void report(const fmi2CallbackFunctions *functions, fmi2String name, fmi2Status status,
                   const char *text)
{
    if (functions && functions->logger) {
        functions->logger(functions->componentEnvironment, name, status,
                          status == fmi2Fatal ? "logStatusFatal" : "logStatusError", "%s", text);
    } else {
        fprintf(stderr, "%s: %s\n", name ? name : MF_MODEL.identifier, text);
    }
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    struct instance *instance;
    char why[MF_WHY_SIZE];
    if (!ready()) {
        report(functions, instanceName, fmi2Fatal, loader_message());
        return NULL;
    }
    if (!instanceName || !*instanceName) {
        report(functions, instanceName, fmi2Error,
               "fmi2Instantiate: instanceName must be a non-empty string");
        return NULL;
    }
    if (!functions) {
        report(functions, instanceName, fmi2Error,
               "fmi2Instantiate: the callback functions are NULL (FMI 2.0 requires them)");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        report(functions, instanceName, fmi2Error,
               "fmi2Instantiate: this FMU supports co-simulation only (fmuType must be "
               "fmi2CoSimulation)");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MF_MODEL.token) != 0) {
        snprintf(why, sizeof why,
                 "fmi2Instantiate: fmuGUID \"%.200s\" is not this FMU's guid \"%s\" (from "
                 "another FMU, or another build of %s?)",
                 fmuGUID ? fmuGUID : "(NULL)", MF_MODEL.token, MF_MODEL.identifier);
        report(functions, instanceName, fmi2Error, why);
        return NULL;
    }
    if (broken) {
        report(functions, instanceName, fmi2Error,
               "fmi2Instantiate refused: pythonfmu's library returned fmi2Fatal earlier in this "
               "process");
        return NULL;
    }
    instance = calloc(1, sizeof *instance);
    if (!instance || !(instance->name = malloc(strlen(instanceName) + 1))) {
        free(instance);
        report(functions, instanceName, fmi2Error, "fmi2Instantiate: out of memory");
        return NULL;
    }
    strcpy(instance->name, instanceName);
    instance->host = *functions;
    instance->proxy = *functions;
    instance->proxy.logger = proxy_logger;
    instance->proxy.componentEnvironment = instance;
    loader_before_interpreter_start();
    instance->real = real.Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation,
                                      &instance->proxy, visible, loggingOn);
    loader_after_interpreter_start();
    if (!instance->real) {
        free(instance->name);
        free(instance);
        return NULL;
    }
    instance->state = INSTANTIATED;
    mf_register(instance);
    return instance;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    struct instance *instance = c;
    if (!c) return;
    if (!mf_registered(c)) {
        unknown_instance("fmi2FreeInstance", c);
        return;
    }
    mf_unregister(instance);
    while (instance->states) {
        if (!broken) real.FreeFMUstate(instance->real, &instance->states->real);
        mf_state_remove(&instance->states, instance->states);
    }
    if (!broken) real.FreeInstance(instance->real);
    free(instance->name);
    free(instance);
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn,
                                           size_t nCategories, const fmi2String categories[])
{
    struct instance *instance = enter(c, "fmi2SetDebugLogging", ANY_STATE);
    char why[MF_WHY_SIZE];
    size_t i;
    if (!instance) return fmi2Error;
    if (nCategories > 0 && !categories) {
        return refuse(instance, "fmi2SetDebugLogging: categories is NULL");
    }
    for (i = 0; i < nCategories; i++) {
        if (!mf_known_category(categories[i])) {
            snprintf(why, sizeof why,
                     "fmi2SetDebugLogging: \"%.200s\" is not one of this FMU's log categories "
                     "(its modelDescription.xml lists them)",
                     categories[i] ? categories[i] : "(NULL)");
            return refuse(instance, why);
        }
    }
    return finish(instance, real.SetDebugLogging(instance->real, loggingOn, nCategories,
                                                 categories));
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance, fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    struct instance *instance = enter(c, "fmi2SetupExperiment", INSTANTIATED);
    char why[MF_WHY_SIZE];
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!isfinite(startTime) || (stopTimeDefined && !(stopTime >= startTime))) {
        snprintf(why, sizeof why,
                 "fmi2SetupExperiment: startTime = %.17g s must be finite and stopTime = %.17g "
                 "s (when defined) not before it",
                 startTime, stopTime);
        return refuse(instance, why);
    }
    status = finish(instance, real.SetupExperiment(instance->real, toleranceDefined, tolerance,
                                                   startTime, stopTimeDefined, stopTime));
    if (status <= fmi2Warning) {
        instance->time = startTime;
        instance->stop = stopTime;
        instance->stop_defined = stopTimeDefined != fmi2False;
    }
    return status;
}

/* A forwarded call that takes the instance from one state to another when it succeeds. */
#define TRANSITION(name, from, to) \
    FMI2_Export fmi2Status fmi2##name(fmi2Component c) \
    { \
        struct instance *instance = enter(c, "fmi2" #name, from); \
        fmi2Status status; \
        if (!instance) return fmi2Error; \
        status = finish(instance, real.name(instance->real)); \
        if (status <= fmi2Warning) instance->state = to; \
        return status; \
    }

TRANSITION(EnterInitializationMode, INSTANTIATED, INITIALIZATION_MODE)
TRANSITION(ExitInitializationMode, INITIALIZATION_MODE, STEP_COMPLETE)
TRANSITION(Terminate, STEP_COMPLETE, TERMINATED)
#undef TRANSITION

FMI2_Export fmi2Status fmi2Reset(fmi2Component c)
{
    struct instance *instance = enter(c, "fmi2Reset", ANY_STATE);
    fmi2Status status;
    if (!instance) return fmi2Error;
    status = finish(instance, real.Reset(instance->real));
    if (status <= fmi2Warning) {
        instance->state = INSTANTIATED;
        instance->time = 0.0;
        instance->stop_defined = 0;
    }
    return status;
}

/* ---- Getting and setting variable values ---- */

/* A set of strings must not hand pythonfmu a NULL string. */
static int strings_ok(struct instance *instance, const char *function, const void *values,
                      size_t n, int type, int setting)
{
    const fmi2String *strings = values;
    size_t i;
    char why[MF_WHY_SIZE];
    if (type != MF_STRING || !setting) return 1;
    for (i = 0; i < n; i++) {
        if (!strings[i]) {
            snprintf(why, sizeof why, "%s: the string at position %zu is NULL", function, i);
            refuse(instance, why);
            return 0;
        }
    }
    return 1;
}

/* the parameter lists of fmi2Get<T> and fmi2Set<T>, named by the verb ACCESS pastes */
#define VALUES_Get(T) (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2##T value[])
#define VALUES_Set(T) \
    (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2##T value[])
#define ACCESS(verb, T, TYPE, allowed, phase) \
    FMI2_Export fmi2Status fmi2##verb##T VALUES_##verb(T) \
    { \
        struct instance *instance = enter(c, "fmi2" #verb #T, allowed); \
        char why[MF_WHY_SIZE]; \
        if (!instance) return fmi2Error; \
        if (!mf_check_references("fmi2" #verb #T, vr, nvr, TYPE, phase, why)) { \
            return refuse(instance, why); \
        } \
        if (nvr > 0 && !value) return refuse(instance, "fmi2" #verb #T ": value is NULL"); \
        if (!strings_ok(instance, "fmi2" #verb #T, value, nvr, TYPE, phase >= 0)) { \
            return fmi2Error; \
        } \
        if (nvr == 0) return fmi2OK; \
        return finish(instance, real.verb##T(instance->real, vr, nvr, value)); \
    }
#define GET_SET(T, TYPE) \
    ACCESS(Get, T, TYPE, READABLE, -1) \
    ACCESS(Set, T, TYPE, WRITABLE, set_phase(instance))
GET_SET(Real, MF_FLOAT64)
GET_SET(Integer, MF_INT32)
GET_SET(Boolean, MF_BOOLEAN)
GET_SET(String, MF_STRING)
#undef GET_SET
#undef ACCESS

/* ---- FMU states ---- */

/* The record of a state the host passes in, or NULL after refusing it. */
static struct mf_state *known_state(struct instance *instance, const char *function,
                                    fmi2FMUstate state)
{
    char why[MF_WHY_SIZE];
    struct mf_state *record = mf_state_known(instance->states, state, function, why);
    if (!record) refuse(instance, why);
    return record;
}

static int state_slot(struct instance *instance, const char *function, fmi2FMUstate *slot,
                      struct mf_state **reuse)
{
    char why[MF_WHY_SIZE];
    if (mf_state_slot(instance->states, slot, function, reuse, why)) return 1;
    refuse(instance, why);
    return 0;
}

static void release_state(void *real_instance, void **state)
{
    real.FreeFMUstate((fmi2Component)real_instance, (fmi2FMUstate *)state);
}

static fmi2Status keep_state(struct instance *instance, fmi2FMUstate *slot, struct mf_state *reuse,
                             void *real_state, int machine, double time)
{
    if (!mf_state_keep(&instance->states, reuse, slot, real_state, machine, time,
                       release_state, instance->real)) {
        return refuse(instance, "out of memory for an FMU state");
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    struct instance *instance = enter(c, "fmi2GetFMUstate", ANY_STATE);
    fmi2FMUstate real_state = NULL;
    struct mf_state *reuse;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!state_slot(instance, "fmi2GetFMUstate", FMUstate, &reuse)) return fmi2Error;
    status = finish(instance, real.GetFMUstate(instance->real, &real_state));
    if (status > fmi2Warning) return status;
    return keep_state(instance, FMUstate, reuse, real_state, instance->state, instance->time);
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    struct instance *instance = enter(c, "fmi2SetFMUstate", ANY_STATE);
    struct mf_state *record;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!(record = known_state(instance, "fmi2SetFMUstate", FMUstate))) return fmi2Error;
    status = finish(instance, real.SetFMUstate(instance->real, record->real));
    if (status <= fmi2Warning) {
        instance->state = record->machine;
        instance->time = record->time;
    }
    return status;
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    struct instance *instance = enter(c, "fmi2FreeFMUstate", ANY_STATE);
    struct mf_state *record;
    if (!instance) return fmi2Error;
    if (!FMUstate) return refuse(instance, "fmi2FreeFMUstate: FMUstate is NULL");
    if (!*FMUstate) return fmi2OK; /* nothing to free */
    if (!(record = known_state(instance, "fmi2FreeFMUstate", *FMUstate))) return fmi2Error;
    real.FreeFMUstate(instance->real, &record->real);
    mf_state_remove(&instance->states, record);
    *FMUstate = NULL;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate,
                                                  size_t *size)
{
    struct instance *instance = enter(c, "fmi2SerializedFMUstateSize", ANY_STATE);
    struct mf_state *record;
    size_t payload = 0;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!(record = known_state(instance, "fmi2SerializedFMUstateSize", FMUstate))) {
        return fmi2Error;
    }
    if (!size) return refuse(instance, "fmi2SerializedFMUstateSize: size is NULL");
    status = finish(instance, real.SerializedFMUstateSize(instance->real, record->real, &payload));
    if (status > fmi2Warning) return status;
    if (payload == 0) {
        return refuse(instance, "fmi2SerializedFMUstateSize: the model's state holds a value "
                                "the state format cannot write");
    }
    *size = mf_frame_size(payload);
    return status;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                             fmi2Byte serializedState[], size_t size)
{
    struct instance *instance = enter(c, "fmi2SerializeFMUstate", ANY_STATE);
    struct mf_state *record;
    char why[MF_WHY_SIZE];
    size_t payload = 0;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!(record = known_state(instance, "fmi2SerializeFMUstate", FMUstate))) return fmi2Error;
    if (!serializedState) return refuse(instance, "fmi2SerializeFMUstate: serializedState is NULL");
    status = finish(instance, real.SerializedFMUstateSize(instance->real, record->real, &payload));
    if (status > fmi2Warning) return status;
    if (payload == 0) {
        return refuse(instance, "fmi2SerializeFMUstate: the model's state holds a value the "
                                "state format cannot write");
    }
    if (size < mf_frame_size(payload)) {
        snprintf(why, sizeof why,
                 "fmi2SerializeFMUstate: size = %zu bytes is less than the %zu the state needs "
                 "(fmi2SerializedFMUstateSize tells it)",
                 size, mf_frame_size(payload));
        return refuse(instance, why);
    }
    status = finish(instance,
                    real.SerializeFMUstate(instance->real, record->real,
                                           (fmi2Byte *)serializedState + mf_frame_payload_offset(),
                                           payload));
    if (status <= fmi2Warning) {
        mf_frame_write((unsigned char *)serializedState, payload, record->machine, record->time);
    }
    return status;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                               size_t size, fmi2FMUstate *FMUstate)
{
    struct instance *instance = enter(c, "fmi2DeSerializeFMUstate", ANY_STATE);
    const unsigned char *payload;
    char why[MF_WHY_SIZE + 32], problem[MF_WHY_SIZE];
    fmi2FMUstate real_state = NULL;
    size_t payload_size;
    double time;
    struct mf_state *reuse;
    int machine;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!mf_frame_read((const unsigned char *)serializedState, size, &payload, &payload_size,
                       &machine, &time, problem)) {
        snprintf(why, sizeof why, "fmi2DeSerializeFMUstate: %s", problem);
        return refuse(instance, why);
    }
    if (machine != INSTANTIATED && machine != INITIALIZATION_MODE && machine != STEP_COMPLETE
        && machine != TERMINATED && machine != ERROR_STATE) {
        return refuse(instance, "fmi2DeSerializeFMUstate: the state names an unknown "
                                "state-machine state");
    }
    if (!state_slot(instance, "fmi2DeSerializeFMUstate", FMUstate, &reuse)) return fmi2Error;
    status = finish(instance, real.DeSerializeFMUstate(instance->real, (const fmi2Byte *)payload,
                                                       payload_size, &real_state));
    if (status > fmi2Warning) return status;
    return keep_state(instance, FMUstate, reuse, real_state, machine, time);
}

/* ---- Capabilities these FMUs do not have (modelDescription.xml says so) ---- */

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"

#define NOT_PROVIDED(name, params, allowed, why) \
    FMI2_Export fmi2Status fmi2##name params \
    { \
        struct instance *instance = enter(c, "fmi2" #name, allowed); \
        if (!instance) return fmi2Error; \
        return refuse(instance, "fmi2" #name ": " why); \
    }

NOT_PROVIDED(GetDirectionalDerivative,
             (fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
              const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
              fmi2Real dvUnknown[]),
             READABLE, "this FMU provides no directional derivatives "
                       "(providesDirectionalDerivative is false)")
NOT_PROVIDED(SetRealInputDerivatives,
             (fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
              const fmi2Integer order[], const fmi2Real value[]),
             WRITABLE, "this FMU cannot interpolate inputs (canInterpolateInputs is false)")
NOT_PROVIDED(GetRealOutputDerivatives,
             (fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
              const fmi2Integer order[], fmi2Real value[]),
             STEP_COMPLETE | TERMINATED | ERROR_STATE,
             "this FMU provides no output derivatives (maxOutputDerivativeOrder is 0)")
NOT_PROVIDED(CancelStep, (fmi2Component c), 0,
             "only a pending step can be canceled, and these FMUs never return fmi2Pending")

/* ---- Co-simulation ---- */

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    struct instance *instance = enter(c, "fmi2DoStep", STEP_COMPLETE);
    char why[MF_WHY_SIZE];
    double end = currentCommunicationPoint + communicationStepSize;
    fmi2Status status;
    if (!instance) return fmi2Error;
    if (!isfinite(currentCommunicationPoint) || !isfinite(communicationStepSize)
        || !(communicationStepSize > 0.0)) {
        snprintf(why, sizeof why,
                 "fmi2DoStep: communicationStepSize = %.17g s at currentCommunicationPoint = "
                 "%.17g s: the step size must be > 0 and both finite (FMI 2.0 section 4.2.2)",
                 communicationStepSize, currentCommunicationPoint);
        return refuse(instance, why);
    }
    if (instance->stop_defined && mf_beyond(end, instance->stop)) {
        snprintf(why, sizeof why,
                 "fmi2DoStep: the step from t = %.17g s by %.17g s ends beyond stopTime = %.17g "
                 "s given to fmi2SetupExperiment",
                 currentCommunicationPoint, communicationStepSize, instance->stop);
        return refuse(instance, why);
    }
    status = finish(instance, real.DoStep(instance->real, currentCommunicationPoint,
                                          communicationStepSize,
                                          noSetFMUStatePriorToCurrentPoint));
    if (status <= fmi2Warning) instance->time = end;
    return status;
}

/* Status kinds this FMU cannot give: fmi2Discard, as section 4.2.3 says. */
static fmi2Status no_status(struct instance *instance, const char *function, int kind)
{
    if (kind < fmi2DoStepStatus || kind > fmi2Terminated) {
        char why[MF_WHY_SIZE];
        snprintf(why, sizeof why, "%s: %d is not an fmi2StatusKind", function, kind);
        return refuse(instance, why);
    }
    say(instance, fmi2Discard,
        "%s: status kind %d cannot be given (these FMUs never return fmi2Pending); "
        "fmi2Discard",
        function, kind);
    return fmi2Discard;
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    struct instance *instance = enter(c, "fmi2GetStatus", STATUS_READABLE);
    if (!instance) return fmi2Error;
    if (!value) return refuse(instance, "fmi2GetStatus: value is NULL");
    return no_status(instance, "fmi2GetStatus", s);
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s,
                                         fmi2Real *value)
{
    struct instance *instance = enter(c, "fmi2GetRealStatus", STATUS_READABLE);
    if (!instance) return fmi2Error;
    if (!value) return refuse(instance, "fmi2GetRealStatus: value is NULL");
    if (s != fmi2LastSuccessfulTime) return no_status(instance, "fmi2GetRealStatus", s);
    *value = instance->time; /* a discarded step leaves it at the step's start */
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s,
                                            fmi2Integer *value)
{
    struct instance *instance = enter(c, "fmi2GetIntegerStatus", STATUS_READABLE);
    if (!instance) return fmi2Error;
    if (!value) return refuse(instance, "fmi2GetIntegerStatus: value is NULL");
    return no_status(instance, "fmi2GetIntegerStatus", s);
}

FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s,
                                            fmi2Boolean *value)
{
    struct instance *instance = enter(c, "fmi2GetBooleanStatus", STATUS_READABLE);
    if (!instance) return fmi2Error;
    if (!value) return refuse(instance, "fmi2GetBooleanStatus: value is NULL");
    if (s != fmi2Terminated) return no_status(instance, "fmi2GetBooleanStatus", s);
    *value = fmi2False; /* these models never ask to end a simulation */
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s,
                                           fmi2String *value)
{
    struct instance *instance = enter(c, "fmi2GetStringStatus", STATUS_READABLE);
    if (!instance) return fmi2Error;
    if (!value) return refuse(instance, "fmi2GetStringStatus: value is NULL");
    return no_status(instance, "fmi2GetStringStatus", s);
}

/* ---- Model exchange: these FMUs are co-simulation only ---- */

#define NOT_MODEL_EXCHANGE(name, params) \
    NOT_PROVIDED(name, params, ANY_STATE, \
                 "a model-exchange function; this FMU is co-simulation only")

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

#pragma GCC diagnostic pop
