/*
 * Two small FMI 3.0 co-simulation FMUs of the suite's own, for testing our master as an
 * importer of FMUs that are not ours (tests/foreign_fmus.py builds them with the system C
 * compiler; their model descriptions are the .xml files beside this one).
 *
 *   -DTEST_SIGNALS  TestSignals: FMI 2.0's TestSignals (fmi2.c) in FMI 3.0 types (Float64,
 *                   Int32, Boolean, String, Enumeration read as Int64), plus a Float32 and a
 *                   UInt8 pair: y32 = 2 u32, w = byte_in + 1.
 *   -DTEST_STAIR    TestStair: counts its steps and asks to end the simulation
 *                   (terminateSimulation) with the step that reaches t = limit.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

#define TEXT 128

typedef struct {
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
    double time;
    int steps;
    double gain, u, x;
    int offset, k, enabled, b;
    long long mode, e;
    char label[TEXT], s[TEXT], s_out[2 * TEXT + 2];
    float u32;
    unsigned char byte_in;
    double limit;
} Instance;

static void copy_text(char *target, fmi3String source)
{
    snprintf(target, TEXT, "%s", source ? source : "");
}

FMI3_Export const char *fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    Instance *instance = calloc(1, sizeof *instance);
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible;
    (void)loggingOn, (void)eventModeUsed, (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables, (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (!instance) return NULL;
    instance->environment = instanceEnvironment;
    instance->log = logMessage;
    instance->gain = 2.0;
    instance->offset = 3;
    instance->enabled = 1;
    copy_text(instance->label, "tag");
    instance->mode = 2;
    instance->u = 0.5;
    instance->k = 1;
    copy_text(instance->s, "in");
    instance->e = 1;
    instance->u32 = 1.5f;
    instance->byte_in = 7;
    instance->limit = 0.75;
    return instance;
}

FMI3_Export void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance instance,
                                                   fmi3Boolean toleranceDefined,
                                                   fmi3Float64 tolerance, fmi3Float64 startTime,
                                                   fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime)
{
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    ((Instance *)instance)->time = startTime;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    (void)instance;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3Terminate(fmi3Instance instance)
{
    (void)instance;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                                           size_t nCategories, const fmi3String categories[])
{
    (void)instance, (void)loggingOn, (void)nCategories, (void)categories;
    return fmi3OK;
}

#define GETTER(T, CT, CASES) \
    FMI3_Export fmi3Status fmi3Get##T(fmi3Instance instance, \
                                      const fmi3ValueReference valueReferences[], \
                                      size_t nValueReferences, CT values[], size_t nValues) \
    { \
        Instance *self = instance; \
        size_t i; \
        (void)self, (void)values; \
        if (nValues != nValueReferences) return fmi3Error; \
        for (i = 0; i < nValueReferences; i++) { \
            switch (valueReferences[i]) { \
                CASES \
            default: return fmi3Error; \
            } \
        } \
        return fmi3OK; \
    }
#define SETTER(T, CT, CASES) \
    FMI3_Export fmi3Status fmi3Set##T(fmi3Instance instance, \
                                      const fmi3ValueReference valueReferences[], \
                                      size_t nValueReferences, const CT values[], \
                                      size_t nValues) \
    { \
        Instance *self = instance; \
        size_t i; \
        (void)self, (void)values; \
        if (nValues != nValueReferences) return fmi3Error; \
        for (i = 0; i < nValueReferences; i++) { \
            switch (valueReferences[i]) { \
                CASES \
            default: return fmi3Error; \
            } \
        } \
        return fmi3OK; \
    }

#ifdef TEST_STAIR
GETTER(Float64, fmi3Float64,
       case 0: values[i] = self->time; break;
       case 1: values[i] = self->limit; break;
       case 3: values[i] = self->time; break;)
SETTER(Float64, fmi3Float64, case 1: self->limit = values[i]; break;)
GETTER(Int32, fmi3Int32, case 2: values[i] = self->steps; break;)
SETTER(Int32, fmi3Int32, )
GETTER(Float32, fmi3Float32, )
SETTER(Float32, fmi3Float32, )
GETTER(UInt8, fmi3UInt8, )
SETTER(UInt8, fmi3UInt8, )
GETTER(Boolean, fmi3Boolean, )
SETTER(Boolean, fmi3Boolean, )
GETTER(Int64, fmi3Int64, )
SETTER(Int64, fmi3Int64, )
GETTER(String, fmi3String, )
SETTER(String, fmi3String, )
#else
static const char *s_out_of(Instance *self)
{
    snprintf(self->s_out, sizeof self->s_out, "%s:%s", self->label, self->s);
    return self->s_out;
}

GETTER(Float64, fmi3Float64,
       case 0: values[i] = self->time; break;
       case 1: values[i] = self->gain; break;
       case 6: values[i] = self->u; break;
       case 11: values[i] = self->enabled ? self->gain * self->u + self->x : self->x; break;
       case 12: values[i] = self->x; break;)
SETTER(Float64, fmi3Float64,
       case 1: self->gain = values[i]; break;
       case 6: self->u = values[i]; break;)
GETTER(Int32, fmi3Int32,
       case 2: values[i] = self->offset; break;
       case 7: values[i] = self->k; break;
       case 13: values[i] = self->k + self->offset + self->steps; break;)
SETTER(Int32, fmi3Int32,
       case 2: self->offset = values[i]; break;
       case 7: self->k = values[i]; break;)
GETTER(Float32, fmi3Float32,
       case 17: values[i] = self->u32; break;
       case 18: values[i] = 2.0f * self->u32; break;)
SETTER(Float32, fmi3Float32, case 17: self->u32 = values[i]; break;)
GETTER(UInt8, fmi3UInt8,
       case 19: values[i] = self->byte_in; break;
       case 20: values[i] = (fmi3UInt8)(self->byte_in + 1); break;)
SETTER(UInt8, fmi3UInt8, case 19: self->byte_in = values[i]; break;)
GETTER(Boolean, fmi3Boolean,
       case 3: values[i] = self->enabled; break;
       case 8: values[i] = self->b; break;
       case 14: values[i] = self->b && self->enabled; break;)
SETTER(Boolean, fmi3Boolean,
       case 3: self->enabled = values[i]; break;
       case 8: self->b = values[i]; break;)
GETTER(Int64, fmi3Int64,
       case 5: values[i] = self->mode; break;
       case 10: values[i] = self->e; break;
       case 15: values[i] = self->e; break;)
SETTER(Int64, fmi3Int64,
       case 5: self->mode = values[i]; break;
       case 10: self->e = values[i]; break;)
GETTER(String, fmi3String,
       case 4: values[i] = self->label; break;
       case 9: values[i] = self->s; break;
       case 16: values[i] = s_out_of(self); break;)
SETTER(String, fmi3String,
       case 4: copy_text(self->label, values[i]); break;
       case 9: copy_text(self->s, values[i]); break;)
#endif

FMI3_Export fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h,
                                  fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                  fmi3Boolean *eventHandlingNeeded,
                                  fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                                  fmi3Float64 *lastSuccessfulTime)
{
    Instance *self = instance;
    (void)noSetFMUStatePriorToCurrentPoint;
    *eventHandlingNeeded = fmi3False;
    *earlyReturn = fmi3False;
    *terminateSimulation = fmi3False;
#ifdef TEST_STAIR
    if (t + h >= self->limit - 1e-12) {
        *terminateSimulation = fmi3True;
        if (self->log) {
            self->log(self->environment, fmi3OK, "logAll",
                      "the stair has reached its limit: end of the simulation");
        }
    }
#else
    self->x += self->u * h;
#endif
    self->steps++;
    self->time = t + h;
    *lastSuccessfulTime = self->time;
    return fmi3OK;
}

/* Everything else: not provided. */
#pragma GCC diagnostic ignored "-Wunused-parameter"
#define STUB(name, params) \
    FMI3_Export fmi3Status fmi3##name params { return fmi3Error; }
#define REFS fmi3Instance instance, const fmi3ValueReference vr[], size_t n
FMI3_Export fmi3Instance fmi3InstantiateModelExchange(fmi3String a, fmi3String b, fmi3String c,
                                                      fmi3Boolean d, fmi3Boolean e,
                                                      fmi3InstanceEnvironment f,
                                                      fmi3LogMessageCallback g)
{
    return NULL;
}
FMI3_Export fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String a, fmi3String b, fmi3String c, fmi3Boolean d, fmi3Boolean e,
    fmi3InstanceEnvironment f, fmi3LogMessageCallback g, fmi3ClockUpdateCallback h,
    fmi3LockPreemptionCallback i, fmi3UnlockPreemptionCallback j)
{
    return NULL;
}
STUB(Reset, (fmi3Instance instance))
STUB(EnterEventMode, (fmi3Instance instance))
STUB(GetInt8, (REFS, fmi3Int8 v[], size_t m))
STUB(SetInt8, (REFS, const fmi3Int8 v[], size_t m))
STUB(GetInt16, (REFS, fmi3Int16 v[], size_t m))
STUB(SetInt16, (REFS, const fmi3Int16 v[], size_t m))
STUB(GetUInt16, (REFS, fmi3UInt16 v[], size_t m))
STUB(SetUInt16, (REFS, const fmi3UInt16 v[], size_t m))
STUB(GetUInt32, (REFS, fmi3UInt32 v[], size_t m))
STUB(SetUInt32, (REFS, const fmi3UInt32 v[], size_t m))
STUB(GetUInt64, (REFS, fmi3UInt64 v[], size_t m))
STUB(SetUInt64, (REFS, const fmi3UInt64 v[], size_t m))
STUB(GetBinary, (REFS, size_t sizes[], fmi3Binary v[], size_t m))
STUB(SetBinary, (REFS, const size_t sizes[], const fmi3Binary v[], size_t m))
STUB(GetClock, (REFS, fmi3Clock v[]))
STUB(SetClock, (REFS, const fmi3Clock v[]))
STUB(GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference r, size_t *n))
STUB(GetVariableDependencies,
     (fmi3Instance instance, fmi3ValueReference d, size_t a[], fmi3ValueReference b[],
      size_t c[], fmi3DependencyKind k[], size_t n))
STUB(GetFMUState, (fmi3Instance instance, fmi3FMUState *state))
STUB(SetFMUState, (fmi3Instance instance, fmi3FMUState state))
STUB(FreeFMUState, (fmi3Instance instance, fmi3FMUState *state))
STUB(SerializedFMUStateSize, (fmi3Instance instance, fmi3FMUState state, size_t *size))
STUB(SerializeFMUState, (fmi3Instance instance, fmi3FMUState state, fmi3Byte b[], size_t n))
STUB(DeserializeFMUState,
     (fmi3Instance instance, const fmi3Byte b[], size_t n, fmi3FMUState *state))
STUB(GetDirectionalDerivative,
     (fmi3Instance instance, const fmi3ValueReference u[], size_t nu,
      const fmi3ValueReference k[], size_t nk, const fmi3Float64 s[], size_t ns,
      fmi3Float64 r[], size_t nr))
STUB(GetAdjointDerivative,
     (fmi3Instance instance, const fmi3ValueReference u[], size_t nu,
      const fmi3ValueReference k[], size_t nk, const fmi3Float64 s[], size_t ns,
      fmi3Float64 r[], size_t nr))
STUB(EnterConfigurationMode, (fmi3Instance instance))
STUB(ExitConfigurationMode, (fmi3Instance instance))
STUB(GetIntervalDecimal, (REFS, fmi3Float64 a[], fmi3IntervalQualifier q[]))
STUB(GetIntervalFraction, (REFS, fmi3UInt64 a[], fmi3UInt64 b[], fmi3IntervalQualifier q[]))
STUB(GetShiftDecimal, (REFS, fmi3Float64 a[]))
STUB(GetShiftFraction, (REFS, fmi3UInt64 a[], fmi3UInt64 b[]))
STUB(SetIntervalDecimal, (REFS, const fmi3Float64 a[]))
STUB(SetIntervalFraction, (REFS, const fmi3UInt64 a[], const fmi3UInt64 b[]))
STUB(SetShiftDecimal, (REFS, const fmi3Float64 a[]))
STUB(SetShiftFraction, (REFS, const fmi3UInt64 a[], const fmi3UInt64 b[]))
STUB(EvaluateDiscreteStates, (fmi3Instance instance))
STUB(UpdateDiscreteStates,
     (fmi3Instance instance, fmi3Boolean *a, fmi3Boolean *b, fmi3Boolean *c, fmi3Boolean *d,
      fmi3Boolean *e, fmi3Float64 *f))
STUB(EnterContinuousTimeMode, (fmi3Instance instance))
STUB(CompletedIntegratorStep,
     (fmi3Instance instance, fmi3Boolean a, fmi3Boolean *b, fmi3Boolean *c))
STUB(SetTime, (fmi3Instance instance, fmi3Float64 t))
STUB(SetContinuousStates, (fmi3Instance instance, const fmi3Float64 x[], size_t n))
STUB(GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 x[], size_t n))
STUB(GetEventIndicators, (fmi3Instance instance, fmi3Float64 x[], size_t n))
STUB(GetContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n))
STUB(GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n))
STUB(GetNumberOfEventIndicators, (fmi3Instance instance, size_t *n))
STUB(GetNumberOfContinuousStates, (fmi3Instance instance, size_t *n))
STUB(EnterStepMode, (fmi3Instance instance))
STUB(GetOutputDerivatives,
     (REFS, const fmi3Int32 orders[], fmi3Float64 values[], size_t m))
STUB(ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference c, fmi3Float64 t))
