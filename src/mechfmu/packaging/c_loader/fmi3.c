/*
 * mechfmu's FMI 3.0 loader: with python_runtime.c, the FMU's binaries/x86_64-linux/<Name>.so
 * when a C compiler was found at build time (src/mechfmu/packaging/build.py).
 *
 * At the first fmi3InstantiateCoSimulation (or fmi3GetVersion) it loads the Python runtime and
 * pythonfmu3's library (python_runtime.c says how and in which order), resolves every FMI 3.0
 * function of that library once, and then forwards every FMI 3.0 call to it unchanged. When
 * loading fails, the instantiation reports why through the host's logger (status fmi3Fatal)
 * and returns NULL. pythonfmu3's library stays loaded until the process exits (RTLD_NODELETE,
 * see python_runtime.c): unloading it would call Py_Finalize under the other FMUs' objects.
 */

#include <stdio.h>

#include "fmi3Functions.h"
#include "python_runtime.h"

/* Every FMI 3.0 function, as X(name, parameters, arguments), except the three instantiation
 * functions, fmi3GetVersion and fmi3FreeInstance, which are written out below. */
#define VALUES_GET(T) \
    (fmi3Instance instance, const fmi3ValueReference valueReferences[], \
     size_t nValueReferences, fmi3##T values[], size_t nValues)
#define VALUES_SET(T) \
    (fmi3Instance instance, const fmi3ValueReference valueReferences[], \
     size_t nValueReferences, const fmi3##T values[], size_t nValues)
#define VALUES_ARGS (instance, valueReferences, nValueReferences, values, nValues)
#define TYPED(X, T) X(Get##T, VALUES_GET(T), VALUES_ARGS) X(Set##T, VALUES_SET(T), VALUES_ARGS)
#define INSTANCE_ONLY (fmi3Instance instance)
#define REFERENCES fmi3Instance instance, const fmi3ValueReference valueReferences[], \
    size_t nValueReferences
#define REFERENCES_ARGS instance, valueReferences, nValueReferences

#define FMI3_FORWARDED(X) \
    X(SetDebugLogging, \
      (fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories, \
       const fmi3String categories[]), \
      (instance, loggingOn, nCategories, categories)) \
    X(EnterInitializationMode, \
      (fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance, \
       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime), \
      (instance, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime)) \
    X(ExitInitializationMode, INSTANCE_ONLY, (instance)) \
    X(EnterEventMode, INSTANCE_ONLY, (instance)) \
    X(Terminate, INSTANCE_ONLY, (instance)) \
    X(Reset, INSTANCE_ONLY, (instance)) \
    TYPED(X, Float32) TYPED(X, Float64) TYPED(X, Int8) TYPED(X, UInt8) TYPED(X, Int16) \
    TYPED(X, UInt16) TYPED(X, Int32) TYPED(X, UInt32) TYPED(X, Int64) TYPED(X, UInt64) \
    TYPED(X, Boolean) TYPED(X, String) \
    X(GetBinary, \
      (REFERENCES, size_t valueSizes[], fmi3Binary values[], size_t nValues), \
      (REFERENCES_ARGS, valueSizes, values, nValues)) \
    X(SetBinary, \
      (REFERENCES, const size_t valueSizes[], const fmi3Binary values[], size_t nValues), \
      (REFERENCES_ARGS, valueSizes, values, nValues)) \
    X(GetClock, (REFERENCES, fmi3Clock values[]), (REFERENCES_ARGS, values)) \
    X(SetClock, (REFERENCES, const fmi3Clock values[]), (REFERENCES_ARGS, values)) \
    X(GetNumberOfVariableDependencies, \
      (fmi3Instance instance, fmi3ValueReference valueReference, size_t *nDependencies), \
      (instance, valueReference, nDependencies)) \
    X(GetVariableDependencies, \
      (fmi3Instance instance, fmi3ValueReference dependent, \
       size_t elementIndicesOfDependent[], fmi3ValueReference independents[], \
       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], \
       size_t nDependencies), \
      (instance, dependent, elementIndicesOfDependent, independents, \
       elementIndicesOfIndependents, dependencyKinds, nDependencies)) \
    X(GetFMUState, (fmi3Instance instance, fmi3FMUState *FMUState), (instance, FMUState)) \
    X(SetFMUState, (fmi3Instance instance, fmi3FMUState FMUState), (instance, FMUState)) \
    X(FreeFMUState, (fmi3Instance instance, fmi3FMUState *FMUState), (instance, FMUState)) \
    X(SerializedFMUStateSize, \
      (fmi3Instance instance, fmi3FMUState FMUState, size_t *size), \
      (instance, FMUState, size)) \
    X(SerializeFMUState, \
      (fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], \
       size_t size), \
      (instance, FMUState, serializedState, size)) \
    X(DeserializeFMUState, \
      (fmi3Instance instance, const fmi3Byte serializedState[], size_t size, \
       fmi3FMUState *FMUState), \
      (instance, serializedState, size, FMUState)) \
    X(GetDirectionalDerivative, \
      (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, \
       const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], \
       size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity), \
      (instance, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, \
       nSensitivity)) \
    X(GetAdjointDerivative, \
      (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, \
       const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], \
       size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity), \
      (instance, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, \
       nSensitivity)) \
    X(EnterConfigurationMode, INSTANCE_ONLY, (instance)) \
    X(ExitConfigurationMode, INSTANCE_ONLY, (instance)) \
    X(GetIntervalDecimal, \
      (REFERENCES, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]), \
      (REFERENCES_ARGS, intervals, qualifiers)) \
    X(GetIntervalFraction, \
      (REFERENCES, fmi3UInt64 counters[], fmi3UInt64 resolutions[], \
       fmi3IntervalQualifier qualifiers[]), \
      (REFERENCES_ARGS, counters, resolutions, qualifiers)) \
    X(GetShiftDecimal, (REFERENCES, fmi3Float64 shifts[]), (REFERENCES_ARGS, shifts)) \
    X(GetShiftFraction, \
      (REFERENCES, fmi3UInt64 counters[], fmi3UInt64 resolutions[]), \
      (REFERENCES_ARGS, counters, resolutions)) \
    X(SetIntervalDecimal, (REFERENCES, const fmi3Float64 intervals[]), \
      (REFERENCES_ARGS, intervals)) \
    X(SetIntervalFraction, \
      (REFERENCES, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), \
      (REFERENCES_ARGS, counters, resolutions)) \
    X(SetShiftDecimal, (REFERENCES, const fmi3Float64 shifts[]), (REFERENCES_ARGS, shifts)) \
    X(SetShiftFraction, \
      (REFERENCES, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), \
      (REFERENCES_ARGS, counters, resolutions)) \
    X(EvaluateDiscreteStates, INSTANCE_ONLY, (instance)) \
    X(UpdateDiscreteStates, \
      (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate, \
       fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged, \
       fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined, \
       fmi3Float64 *nextEventTime), \
      (instance, discreteStatesNeedUpdate, terminateSimulation, \
       nominalsOfContinuousStatesChanged, valuesOfContinuousStatesChanged, \
       nextEventTimeDefined, nextEventTime)) \
    X(EnterContinuousTimeMode, INSTANCE_ONLY, (instance)) \
    X(CompletedIntegratorStep, \
      (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, \
       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation), \
      (instance, noSetFMUStatePriorToCurrentPoint, enterEventMode, terminateSimulation)) \
    X(SetTime, (fmi3Instance instance, fmi3Float64 time), (instance, time)) \
    X(SetContinuousStates, \
      (fmi3Instance instance, const fmi3Float64 continuousStates[], \
       size_t nContinuousStates), \
      (instance, continuousStates, nContinuousStates)) \
    X(GetContinuousStateDerivatives, \
      (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates), \
      (instance, derivatives, nContinuousStates)) \
    X(GetEventIndicators, \
      (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators), \
      (instance, eventIndicators, nEventIndicators)) \
    X(GetContinuousStates, \
      (fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates), \
      (instance, continuousStates, nContinuousStates)) \
    X(GetNominalsOfContinuousStates, \
      (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates), \
      (instance, nominals, nContinuousStates)) \
    X(GetNumberOfEventIndicators, (fmi3Instance instance, size_t *nEventIndicators), \
      (instance, nEventIndicators)) \
    X(GetNumberOfContinuousStates, (fmi3Instance instance, size_t *nContinuousStates), \
      (instance, nContinuousStates)) \
    X(EnterStepMode, INSTANCE_ONLY, (instance)) \
    X(GetOutputDerivatives, \
      (REFERENCES, const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues), \
      (REFERENCES_ARGS, orders, values, nValues)) \
    X(DoStep, \
      (fmi3Instance instance, fmi3Float64 currentCommunicationPoint, \
       fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint, \
       fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, \
       fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime), \
      (instance, currentCommunicationPoint, communicationStepSize, \
       noSetFMUStatePriorToCurrentPoint, eventHandlingNeeded, terminateSimulation, \
       earlyReturn, lastSuccessfulTime)) \
    X(ActivateModelPartition, \
      (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime), \
      (instance, clockReference, activationTime))

/* Every function of the real library, resolved once. */
#define POINTER(name, params, args) fmi3##name##TYPE *name;
static struct {
    fmi3GetVersionTYPE *GetVersion;
    fmi3InstantiateCoSimulationTYPE *InstantiateCoSimulation;
    fmi3FreeInstanceTYPE *FreeInstance;
    FMI3_FORWARDED(POINTER)
} real;
#undef POINTER

static int load_state; /* 0: not tried, 1: loaded, -1: failed (loader_message says why) */

static int resolve_functions(void *library)
{
#define REQUIRED(name) real.name = (fmi3##name##TYPE *)loader_function(library, "fmi3" #name, 1);
#define OPTIONAL(name, params, args) \
    real.name = (fmi3##name##TYPE *)loader_function(library, "fmi3" #name, 0);
    REQUIRED(GetVersion)
    REQUIRED(InstantiateCoSimulation)
    REQUIRED(FreeInstance)
    FMI3_FORWARDED(OPTIONAL)
#undef REQUIRED
#undef OPTIONAL
    return !loader_missing_functions("pythonfmu3's library");
}

/* Loads once; 1 when every call can be forwarded (see loader_ready). */
static int ready(void)
{
    return loader_ready(&load_state, resolve_functions);
}

static void report_failure(fmi3InstanceEnvironment environment, fmi3LogMessageCallback logger,
                           fmi3String instanceName)
{
    if (logger) {
        logger(environment, fmi3Fatal, "logStatusFatal", loader_message());
    } else {
        fprintf(stderr, "%s: %s\n", instanceName ? instanceName : "FMU", loader_message());
    }
}

/* ---- Written out: version, instantiation, freeing ---- */

FMI3_Export const char *fmi3GetVersion(void)
{
    return ready() ? real.GetVersion() : fmi3Version;
}

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    fmi3Instance instance;
    if (!ready()) {
        report_failure(instanceEnvironment, logMessage, instanceName);
        return NULL;
    }
    loader_before_interpreter_start();
    instance = real.InstantiateCoSimulation(
        instanceName, instantiationToken, resourcePath, visible, loggingOn, eventModeUsed,
        earlyReturnAllowed, requiredIntermediateVariables, nRequiredIntermediateVariables,
        instanceEnvironment, logMessage, intermediateUpdate);
    loader_after_interpreter_start();
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
    if (logMessage) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU is co-simulation only: use fmi3InstantiateCoSimulation");
    }
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

FMI3_Export void fmi3FreeInstance(fmi3Instance instance)
{
    if (instance && load_state == 1) real.FreeInstance(instance);
}

/* ---- Every other function: forwarded when loaded and present, fmi3Error otherwise ---- */

#define FORWARD(name, params, args) \
    LOADER_FORWARD(FMI3_Export, fmi3Status, fmi3##name, fmi3Error, name, params, args)
FMI3_FORWARDED(FORWARD)
#undef FORWARD
