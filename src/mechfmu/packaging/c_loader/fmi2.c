/*
 * mechfmu's FMI 2.0 loader: with python_runtime.c, the FMU's binaries/linux64/<Name>.so when
 * a C compiler was found at build time (src/mechfmu/packaging/build.py).
 *
 * At the first fmi2Instantiate (or fmi2GetVersion/GetTypesPlatform) it loads the Python
 * runtime and pythonfmu's library (python_runtime.c says how and in which order), resolves
 * every FMI 2.0 function of that library once, and then forwards every FMI 2.0 call to it
 * unchanged. When loading fails, fmi2Instantiate reports why through the host's logger (status
 * fmi2Fatal) and returns NULL.
 */

#include <stdio.h>

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

static int load_state; /* 0: not tried, 1: loaded, -1: failed (loader_message says why) */

static int resolve_functions(void *library)
{
#define REQUIRED(name) real.name = (fmi2##name##TYPE *)loader_function(library, "fmi2" #name, 1)
#define OPTIONAL(name) real.name = (fmi2##name##TYPE *)loader_function(library, "fmi2" #name, 0)
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
    return !loader_missing_functions("pythonfmu's library");
}

/* Loads once; 1 when every call can be forwarded (see loader_ready). */
static int ready(void)
{
    return loader_ready(&load_state, resolve_functions);
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
    fmi2Component instance;
    if (!ready()) {
        if (functions && functions->logger) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Fatal,
                              "logStatusFatal", "%s", loader_message());
        } else {
            fprintf(stderr, "%s: %s\n", instanceName ? instanceName : "FMU", loader_message());
        }
        return NULL;
    }
    loader_before_interpreter_start();
    instance = real.Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, functions,
                                visible, loggingOn);
    loader_after_interpreter_start();
    return instance;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    if (c && load_state == 1) real.FreeInstance(c);
}

/* Every other function: forwarded when loaded and present, fmi2Error otherwise. */
#define FORWARD(name, params, args) \
    LOADER_FORWARD(FMI2_Export, fmi2Status, fmi2##name, fmi2Error, name, params, args)

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
#define VALUES_GET(T) (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2##T value[])
#define VALUES_SET(T) \
    (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2##T value[])
#define TYPED(T) \
    FORWARD(Get##T, VALUES_GET(T), (c, vr, nvr, value)) \
    FORWARD(Set##T, VALUES_SET(T), (c, vr, nvr, value))
TYPED(Real)
TYPED(Integer)
TYPED(Boolean)
TYPED(String)
#undef TYPED
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
