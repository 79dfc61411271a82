/*
 * mechfmu's C loader, shared part: finds and starts the Python runtime for pythonfmu's library
 * and loads that library. fmi2.c (FMI 2.0) and fmi3.c (FMI 3.0) export the FMI functions and
 * forward them; with this file they make an FMU's binaries/<platform>/<Name>.so when a C
 * compiler was found at build time (src/mechfmu/packaging/build.py).
 *
 * Why: pythonfmu's (and pythonfmu3's) Linux library leaves the Python C API unresolved: it
 * expects a process that already has libpython's symbols in its global scope, as a Python
 * host does. A C or C++ host that dlopens it fails with "undefined symbol: _Py_NoneStruct".
 *
 * At the first call (fmi2Instantiate, fmi3InstantiateCoSimulation, GetVersion...):
 *
 *   1. The host's own Python, when the process already has the C API in its global scope
 *      (fmpy in a Python process): used as it is, no other is loaded.
 *   2. Otherwise a libpython: the file named by $MECHFMU_LIBPYTHON first; then, for the
 *      build's Python version first and then every 3.x from 3.40 down to 3.10 (newest first),
 *      libpython3.x.so.1.0, libpython3.x.so and libpython3.xt.so.1.0 in each of these folders:
 *        - the FMU's own resources/python/lib (mechfmu build --embed-python puts one there);
 *        - $PYTHONHOME/lib; the build Python's LIBDIR; each folder of $LD_LIBRARY_PATH;
 *        - the usual system folders: /usr/local/lib64, /usr/local/lib,
 *          /usr/lib/x86_64-linux-gnu, /usr/lib64, /usr/lib;
 *        - $CONDA_PREFIX/lib (an active conda environment);
 *        - the Python installations of version managers, which are not on the linker's path:
 *          $PYENV_ROOT/versions/(each)/lib (default ~/.pyenv), uv's
 *          $UV_PYTHON_INSTALL_DIR/(each)/lib (default ~/.local/share/uv/python), and GitHub
 *          Actions' /opt/hostedtoolcache/Python/(each)/x64/lib;
 *      and then libpython3.x.so.1.0 through the dynamic linker (ld.so.cache, /lib, ...).
 *      A library is taken only if Py_GetVersion says 3.10 or newer and not a free-threaded
 *      build (pythonfmu's library reads and writes reference counts directly, with the layout
 *      of the GIL build; a free-threaded interpreter would be corrupted): those are refused,
 *      with the reason, and the search goes on. It is loaded RTLD_NOW | RTLD_GLOBAL.
 *   3. pythonfmu's library, <Name>.pythonfmu.so next to this file, with RTLD_NODELETE: it
 *      stays loaded until the process exits even when the host unloads the FMU, because
 *      unloading it runs its C++ destructors, which call Py_Finalize when it started the
 *      interpreter, under the objects of every other FMU in the process that still uses it.
 *   4. The interpreter's home (its standard library) is the folder above the loaded library
 *      that holds lib/python3.x/os.py or lib/python3x.zip, x read from Py_GetVersion at run
 *      time. pythonfmu starts the interpreter itself (Py_Initialize) at its first
 *      instantiation; PYTHONHOME, the documented replacement of the deprecated
 *      Py_SetPythonHome, is set around that call and removed after it (a PYTHONHOME set by
 *      the user is left alone). Without it an embedded interpreter may take the standard
 *      library of another Python found on PATH ("No module named 'math'").
 *
 * When loading fails, the message names every library tried and why, the folders looked in
 * and the names asked of the dynamic linker; the FMI side reports it through the host's logger.
 *
 * Standard C, POSIX and <dlfcn.h> only. Build-time definitions (strings):
 *   PYTHON_SONAME   the libpython the FMU was built with, e.g. "libpython3.11.so.1.0"
 *   PYTHON_LIBDIR   the directory it was in on the build machine
 *   PYTHON_VERSION  its major.minor, e.g. "3.11"
 */

#define _GNU_SOURCE /* RTLD_DEFAULT, RTLD_NODELETE, dladdr */
#include "python_runtime.h"

#include <dlfcn.h>
#include <glob.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef PYTHON_SONAME
#error "define PYTHON_SONAME, e.g. -DPYTHON_SONAME=\"libpython3.11.so.1.0\""
#endif
#ifndef PYTHON_LIBDIR
#define PYTHON_LIBDIR ""
#endif
#ifndef PYTHON_VERSION
#error "define PYTHON_VERSION, e.g. -DPYTHON_VERSION=\"3.11\""
#endif

#define OLDEST_MINOR 10
#define NEWEST_MINOR 40
#define MAX_FOLDERS 96
#define MESSAGE_SIZE 16384
#define INNER_SUFFIX ".pythonfmu.so"

static char message[MESSAGE_SIZE];  /* why loading failed */
static char own_path[PATH_MAX];      /* this library's absolute path, taken when it is loaded */
static char python_home[PATH_MAX];   /* the home of the libpython loaded here; "" for none */
static int home_set_here;            /* PYTHONHOME set by loader_before_interpreter_start */
static int missing_function;         /* a required function of pythonfmu's library is missing */
static void *real_library;           /* pythonfmu's library, once loaded */

static char folders[MAX_FOLDERS][PATH_MAX]; /* where libpython is looked for, in order */
static int folder_count;

static void append(const char *format, ...)
{
    size_t used = strlen(message);
    va_list args;
    if (used + 1 >= sizeof message) return;
    va_start(args, format);
    vsnprintf(message + used, sizeof message - used, format, args);
    va_end(args);
}

const char *loader_message(void)
{
    return message;
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

/* The host unloads this FMU: drop our reference to pythonfmu's library (RTLD_NODELETE keeps
 * it mapped; see step 3 above). */
__attribute__((destructor)) static void release_real_library(void)
{
    if (real_library) dlclose(real_library);
    real_library = NULL;
}

/* ---- The search ---- */

static void add_folder(const char *folder)
{
    int i;
    if (!folder || !*folder || folder_count == MAX_FOLDERS) return;
    for (i = 0; i < folder_count; i++) {
        if (strcmp(folders[i], folder) == 0) return;
    }
    snprintf(folders[folder_count++], PATH_MAX, "%s", folder);
}

static void add_folder_below(const char *base, const char *below)
{
    char folder[PATH_MAX];
    if (!base || !*base) return;
    snprintf(folder, sizeof folder, "%s%s", base, below);
    add_folder(folder);
}

/* Every folder matching a glob(3) pattern, in glob's (sorted) order. */
static void add_folders_matching(const char *pattern)
{
    glob_t found;
    size_t i;
    if (glob(pattern, GLOB_ONLYDIR, NULL, &found) != 0) return;
    for (i = 0; i < found.gl_pathc; i++) add_folder(found.gl_pathv[i]);
    globfree(&found);
}

static void add_home_installations(const char *variable, const char *default_below,
                                   const char *pattern)
{
    char base[PATH_MAX], full[PATH_MAX + 64];
    const char *value = getenv(variable), *home = getenv("HOME");
    if (value && *value) {
        snprintf(base, sizeof base, "%s", value);
    } else if (home && *home) {
        snprintf(base, sizeof base, "%s%s", home, default_below);
    } else {
        return;
    }
    snprintf(full, sizeof full, "%s%s", base, pattern);
    add_folders_matching(full);
}

static void collect_folders(void)
{
    char fmu_lib[PATH_MAX], *end;
    const char *library_path = getenv("LD_LIBRARY_PATH");

    folder_count = 0;
    /* own_path is <fmu>/binaries/<platform>/<Name>.so */
    snprintf(fmu_lib, sizeof fmu_lib, "%s", own_path);
    if ((end = strrchr(fmu_lib, '/'))) *end = '\0';
    if ((end = strrchr(fmu_lib, '/'))) *end = '\0';
    if ((end = strrchr(fmu_lib, '/'))) {
        snprintf(end, sizeof fmu_lib - (size_t)(end - fmu_lib), "/resources/python/lib");
        add_folder(fmu_lib);
    }
    add_folder_below(getenv("PYTHONHOME"), "/lib");
    add_folder(PYTHON_LIBDIR);
    if (library_path) {
        char copy[PATH_MAX * 4], *part, *rest = NULL;
        snprintf(copy, sizeof copy, "%s", library_path);
        for (part = strtok_r(copy, ":", &rest); part; part = strtok_r(NULL, ":", &rest)) {
            add_folder(part);
        }
    }
    add_folder("/usr/local/lib64");
    add_folder("/usr/local/lib");
    add_folder("/usr/lib/x86_64-linux-gnu");
    add_folder("/usr/lib64");
    add_folder("/usr/lib");
    add_folder_below(getenv("CONDA_PREFIX"), "/lib");
    add_home_installations("PYENV_ROOT", "/.pyenv", "/versions/*/lib");
    add_home_installations("UV_PYTHON_INSTALL_DIR", "/.local/share/uv/python", "/*/lib");
    add_folders_matching("/opt/hostedtoolcache/Python/*/x64/lib");
}

/* major.minor and free threading from a Py_GetVersion() string such as
 * "3.13.0 experimental free-threading build (main, ...) [GCC ...]". */
static int parse_version(const char *version, int *major, int *minor)
{
    return version && sscanf(version, "%d.%d", major, minor) == 2;
}

static int is_free_threaded(const char *version)
{
    return version && strstr(version, "free-threading") != NULL;
}

/* Why a Python runtime of this version cannot serve, or NULL when it can. */
static const char *refusal(const char *version)
{
    int major, minor;
    if (!parse_version(version, &major, &minor)) return "not a Python runtime (no version)";
    if (is_free_threaded(version)) {
        return "a free-threaded build: pythonfmu's library handles reference counts with the "
               "layout of the GIL build and would corrupt it; use the default (GIL) build";
    }
    if (major != 3 || minor < OLDEST_MINOR) return "older than Python 3.10";
    return NULL;
}

/* The interpreter's home: the first folder above the library (up to 4 levels) with
 * lib/python3.x/os.py or lib/python3x.zip. */
static void find_home(const char *library, int minor)
{
    char prefix[PATH_MAX], landmark[PATH_MAX + 64];
    int level;
    python_home[0] = '\0';
    if (!realpath(library, prefix)) return;
    for (level = 0; level < 4; level++) {
        char *slash = strrchr(prefix, '/');
        if (!slash || slash == prefix) return;
        *slash = '\0';
        snprintf(landmark, sizeof landmark, "%s/lib/python3.%d/os.py", prefix, minor);
        if (access(landmark, R_OK) == 0) break;
        snprintf(landmark, sizeof landmark, "%s/lib/python3%d.zip", prefix, minor);
        if (access(landmark, R_OK) == 0) break;
    }
    if (level < 4) snprintf(python_home, sizeof python_home, "%s", prefix);
}

/* Loads ``path`` (a path, or a bare name for the dynamic linker) as the process's libpython
 * when it is one we can use; otherwise notes why not (a bare name that the linker does not
 * know is not noted: the summary names those). */
static int try_library(const char *path, int by_name)
{
    typedef const char *get_version_t(void);
    void *probe = dlopen(path, RTLD_LAZY | RTLD_LOCAL);
    get_version_t *get_version;
    const char *why, *version, *error;
    char where[PATH_MAX];
    Dl_info info;
    int major, minor;

    if (!probe) {
        error = dlerror();
        if (by_name) return 0;
        if (error && strstr(error, path)) {
            append("\n  %s", error); /* dlerror names the file itself */
        } else {
            append("\n  %s: %s", path, error ? error : "cannot be loaded");
        }
        return 0;
    }
    get_version = (get_version_t *)dlsym(probe, "Py_GetVersion");
    version = get_version ? get_version() : NULL;
    snprintf(where, sizeof where, "%s", path);
    if (get_version && dladdr((void *)get_version, &info) && info.dli_fname) {
        snprintf(where, sizeof where, "%s", info.dli_fname);
    }
    why = refusal(version);
    if (why) {
        append("\n  %s: refused, %s%s%.60s%s", where, why, version ? " (version " : "",
               version ? version : "", version ? ")" : "");
        dlclose(probe);
        return 0;
    }
    if (!dlopen(path, RTLD_NOW | RTLD_GLOBAL)) {
        error = dlerror();
        append("\n  %s: %s", where, error ? error : "cannot be loaded globally");
        dlclose(probe);
        return 0;
    }
    dlclose(probe); /* the global handle keeps it */
    parse_version(version, &major, &minor);
    find_home(where, minor);
    return 1;
}

static int try_version(int minor)
{
    static const char *const patterns[] = {"%s/libpython3.%d.so.1.0", "%s/libpython3.%d.so",
                                           "%s/libpython3.%dt.so.1.0"};
    char path[PATH_MAX + 64], name[64];
    int i, j;
    for (i = 0; i < folder_count; i++) {
        for (j = 0; j < (int)(sizeof patterns / sizeof *patterns); j++) {
            snprintf(path, sizeof path, patterns[j], folders[i], minor);
            if (access(path, F_OK) == 0 && try_library(path, 0)) return 1;
        }
    }
    snprintf(name, sizeof name, "libpython3.%d.so.1.0", minor);
    return try_library(name, 1);
}

static int build_minor(void)
{
    int major = 0, minor = 0;
    sscanf(PYTHON_VERSION, "%d.%d", &major, &minor);
    return minor;
}

static int load_python(void)
{
    typedef const char *get_version_t(void);
    get_version_t *host_version = (get_version_t *)dlsym(RTLD_DEFAULT, "Py_GetVersion");
    const char *explicit_library = getenv("MECHFMU_LIBPYTHON");
    size_t header_end;
    int minor, i;

    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized") != NULL) {
        /* the host has the Python C API loaded globally: use it, load no other */
        const char *why = refusal(host_version ? host_version() : NULL);
        if (why) {
            append("the Python runtime of this process (%.60s) cannot run this FMU: it is %s",
                   host_version ? host_version() : "?", why);
            return 0;
        }
        return 1;
    }
    append("no usable Python runtime found: this FMU runs its model in Python and needs the "
           "shared library of CPython 3.10 or newer (built with " PYTHON_VERSION
           ", any 3.x >= 3.10 serves). Tried:");
    if (explicit_library && *explicit_library && try_library(explicit_library, 0)) {
        message[0] = '\0';
        return 1;
    }
    collect_folders();
    header_end = strlen(message);
    if (try_version(build_minor())) {
        message[0] = '\0';
        return 1;
    }
    for (minor = NEWEST_MINOR; minor >= OLDEST_MINOR; minor--) {
        if (minor != build_minor() && try_version(minor)) {
            message[0] = '\0';
            return 1;
        }
    }
    if (strlen(message) == header_end) append("\n  (no libpython file found)");
    append("\nLooked for libpython3.x.so.1.0, libpython3.x.so and libpython3.xt.so.1.0 "
           "(x = %d, then %d down to %d) in:", build_minor(), NEWEST_MINOR, OLDEST_MINOR);
    for (i = 0; i < folder_count; i++) append("\n  %s", folders[i]);
    append("\nand asked the dynamic linker for libpython3.x.so.1.0 (LD_LIBRARY_PATH, "
           "ld.so.cache, /lib, /usr/lib): none found.\nInstall CPython 3.10 or newer with its "
           "shared library (e.g. Debian's libpython3.11, or pyenv with --enable-shared), set "
           "MECHFMU_LIBPYTHON to the path of a libpython3.x.so, or use an FMU built with "
           "mechfmu build --embed-python.");
    return 0;
}

/* ---- pythonfmu's library ---- */

void *loader_function(void *library, const char *name, int required)
{
    void *address = dlsym(library, name);
    if (!address && required) {
        const char *error = dlerror();
        append("%s%s", missing_function ? "; " : "", error ? error : name);
        missing_function = 1;
    }
    return address;
}

int loader_missing_functions(const char *library_kind)
{
    if (missing_function) {
        char detail[MESSAGE_SIZE];
        memcpy(detail, message, sizeof detail);
        message[0] = '\0';
        append("%s lacks FMI functions: %s", library_kind, detail);
    }
    return missing_function;
}

int loader_ready(int *state, int (*resolve)(void *library))
{
    if (*state == 0) {
        void *library = loader_open();
        *state = (library && resolve(library)) ? 1 : -1;
    }
    return *state == 1;
}

void *loader_open(void)
{
    char inner[PATH_MAX];
    size_t length = strlen(own_path);
    const char *error;

    message[0] = '\0';
    dlerror();
    if (!load_python()) return NULL;
    if (length < 3 || strcmp(own_path + length - 3, ".so") != 0
        || length - 3 + sizeof INNER_SUFFIX > sizeof inner) {
        append("cannot tell the path of pythonfmu's library from this loader's path '%s'",
               own_path);
        return NULL;
    }
    memcpy(inner, own_path, length - 3);
    strcpy(inner + length - 3, INNER_SUFFIX);
    real_library = dlopen(inner, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
    if (!real_library) {
        error = dlerror();
        append("cannot load pythonfmu's library: %s", error ? error : inner);
    }
    return real_library;
}

/* ---- The interpreter's home ---- */

void loader_before_interpreter_start(void)
{
    typedef int is_initialized_t(void);
    is_initialized_t *is_initialized = (is_initialized_t *)dlsym(RTLD_DEFAULT,
                                                                 "Py_IsInitialized");
    const char *user_home = getenv("PYTHONHOME");
    if (!python_home[0] || !is_initialized || is_initialized() || (user_home && *user_home)) {
        return;
    }
    home_set_here = setenv("PYTHONHOME", python_home, 1) == 0;
}

void loader_after_interpreter_start(void)
{
    if (home_set_here) unsetenv("PYTHONHOME");
    home_set_here = 0;
}
