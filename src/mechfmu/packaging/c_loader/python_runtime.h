/*
 * mechfmu's C loader: the part shared by FMI 2.0 (fmi2.c) and FMI 3.0 (fmi3.c). See
 * python_runtime.c for how the Python runtime is found and started.
 */
#ifndef MECHFMU_PYTHON_RUNTIME_H
#define MECHFMU_PYTHON_RUNTIME_H

/* Loads the Python runtime and pythonfmu's library (<Name>.pythonfmu.so next to this loader)
 * once; returns that library's handle, or NULL with the reason in loader_message(). */
void *loader_open(void);

/* Why loader_open failed (empty when it did not). */
const char *loader_message(void);

/* Around pythonfmu's first instantiation, which starts the interpreter: points the
 * interpreter to the standard library of the libpython loaded here, then restores the
 * environment. Harmless when the interpreter is already running. */
void loader_before_interpreter_start(void);
void loader_after_interpreter_start(void);

/* Resolves a function of pythonfmu's library; a missing required one is noted for
 * loader_missing_functions. */
void *loader_function(void *library, const char *name, int required);

/* 1 (and the reason in loader_message()) when a required function was missing. */
int loader_missing_functions(const char *library_kind);

/* Loads once (loader_open, then ``resolve`` on the library); 1 when every call can be
 * forwarded. ``state``: 0 not tried, 1 loaded, -1 failed (loader_message says why). Not
 * thread-safe: the host's first instantiation must not race another call into this FMU
 * (hosts instantiate in turn). */
int loader_ready(int *state, int (*resolve)(void *library));

#endif
