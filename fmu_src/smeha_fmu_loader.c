/* The FMU's binary: finds a Python at run time, then hands every FMI call to pythonfmu's.
 *
 * A pythonfmu binary calls the Python C API but brings no Python. This loader is what a
 * host opens as binaries/<platform>/<modelIdentifier>.so. At the first instantiation it
 * finds a CPython >= 3.11 that has the packages the FMU needs, in this order (docs/FMU.md,
 * "Run time: which Python"):
 *
 *   1. a Python already in the host process (fmpy, a Python tool): used as it is;
 *   2. SMEHA_FMU_PYTHON, a Python executable or the prefix holding bin/python3;
 *   3. the python3 on PATH;
 *   4. the system's shared libpython (SYSTEM_LIBPYTHONS, the dynamic linker's search).
 *
 * The FMU names no path of the machine that built it: its record (RECORD_FILE) holds the
 * packages it needs ("required") and the building interpreter's version.
 *
 * Each executable is asked (a child process) for its version, its shared libpython and
 * whether it finds the packages; the first that qualifies is loaded with RTLD_GLOBAL (so
 * that its extension modules see the C API) and initialised with that executable as its
 * program name (so that its prefix, venv and site-packages are the executable's). Then
 * pythonfmu's binary, SMEHA_TARGET next to this one, is opened and every FMI call is
 * forwarded to it (the forwarders are generated from the standard's header at build time,
 * smeha.fmu.loader). When no Python qualifies, instantiation returns NULL and logs, whatever
 * loggingOn says, what was tried and how to point the FMU at a Python.
 *
 * Status: pythonfmu 0.7 answers any exception of the slave with Fatal. A slave that has
 * kept itself usable says so just before it raises, with a log message of the category
 * RECOVERABLE (smeha_fmu_base.fail_step_fmi2). The loader's logger relay takes that word
 * for itself (no host sees it), drops pythonfmu's Fatal message that follows (the slave has
 * logged the reason as Error) and the call returns Error instead of Fatal: FMI 2.0.4 keeps
 * Fatal for a model that is corrupted for all instances. Every other Fatal stays Fatal.
 *
 * Build defines: SMEHA_FMI (2 or 3), SMEHA_TARGET (file name), SMEHA_MODEL (model name);
 * smeha_fmu_forward.h (generated) defines the forwarders, resolve_targets() and the
 * T_<function> pointers; smeha_fmu_probe.h (generated from smeha_fmu_probe.py, the build's
 * own libpython search) the PROBE each candidate runs, MIN_HEXVERSION and
 * SYSTEM_LIBPYTHONS.
 */
#if !defined(SMEHA_FMI) || (SMEHA_FMI != 2 && SMEHA_FMI != 3)
#error "define SMEHA_FMI as 2 or 3 (smeha.fmu.loader.compile_loader does)"
#endif
#if !defined(SMEHA_TARGET) || !defined(SMEHA_MODEL)
#error "define SMEHA_TARGET and SMEHA_MODEL (smeha.fmu.loader.compile_loader does)"
#endif

#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <wchar.h>

#if SMEHA_FMI == 2
#include "fmi2Functions.h"
typedef fmi2Status Status;
#define STATUS_ERROR fmi2Error
#define STATUS_FATAL fmi2Fatal
#else
#include "fmi3Functions.h"
typedef fmi3Status Status;
#define STATUS_ERROR fmi3Error
#define STATUS_FATAL fmi3Fatal
#endif

extern char **environ;

#include "smeha_fmu_probe.h"

#define ENV_PYTHON "SMEHA_FMU_PYTHON"
#define RECORD_FILE "smeha_fmu_environment.txt"
#define RECOVERABLE "smehaRecoverable" /* a log category */
#define TEXT_MAX 8192

/* One instance as the host sees it: pythonfmu's instance and the host's callbacks. */
#define MAX_CATEGORIES 32

typedef struct {
    void *target;
    int recoverable; /* the slave reported a recoverable error during the current call */
    int logging_on;  /* what the host asked for (pythonfmu itself always logs, see below) */
    size_t n_categories;
    char *categories[MAX_CATEGORIES];
#if SMEHA_FMI == 2
    fmi2CallbackFunctions host, relay;
#else
    fmi3InstanceEnvironment host_environment;
    fmi3LogMessageCallback host_log;
    fmi3IntermediateUpdateCallback host_update;
#endif
} Instance;

static Status settle(Instance *in, Status status)
{
    if (status == STATUS_FATAL && in->recoverable)
        status = STATUS_ERROR;
    in->recoverable = 0;
    return status;
}

/* What the relay does with a message: 1 pass it on, 0 keep it from the host.
 *
 * pythonfmu drops every message of an instance whose host turned logging off, the slave's
 * word to this loader too; so pythonfmu always logs, and the relay applies the host's
 * setting: Error and Fatal always reach the host (they say why a call failed), the others
 * when logging is on and their category is one the host asked for (any, when it named none).
 */
static int relay_message(Instance *in, int status, const char *category)
{
    if (category && strcmp(category, RECOVERABLE) == 0) {
        in->recoverable = 1;
        return 0;
    }
    if (status == STATUS_FATAL && in->recoverable)
        return 0; /* pythonfmu's message for it: the slave has logged the reason */
    if (status >= STATUS_ERROR)
        return 1;
    if (!in->logging_on)
        return 0;
    for (size_t i = 0; i < in->n_categories; i++)
        if (category && strcmp(category, in->categories[i]) == 0)
            return 1;
    return in->n_categories == 0;
}

static void set_categories(Instance *in, int logging_on, size_t n, const char *const names[])
{
    for (size_t i = 0; i < in->n_categories; i++)
        free(in->categories[i]);
    in->n_categories = 0;
    in->logging_on = logging_on;
    for (size_t i = 0; i < n && names && in->n_categories < MAX_CATEGORIES; i++)
        if (names[i] && (in->categories[in->n_categories] = strdup(names[i])))
            in->n_categories++;
}

/* fmi2/3SetDebugLogging: the host's wish, kept for the relay; pythonfmu keeps logging. */
static Status set_debug_logging(Instance *in, int logging_on, size_t n, const char *const names[])
{
    if (!in)
        return STATUS_ERROR;
    set_categories(in, logging_on, n, names);
    return (Status)0; /* OK */
}

/* fmi2/3FreeInstance: pythonfmu's instance (free_target, when resolved), then ours. */
static void free_instance(Instance *in, void (*free_target)(void *))
{
    if (!in)
        return;
    if (free_target)
        free_target(in->target);
    set_categories(in, 0, 0, NULL);
    free(in);
}

/* ---- the search --------------------------------------------------------------------- */
static pthread_mutex_t search_lock = PTHREAD_MUTEX_INITIALIZER;
/* Where the search stands; every state but SEARCH_PENDING is final for the process. */
typedef enum {
    SEARCH_PENDING,     /* not searched yet, or still searching */
    SEARCH_READY,       /* a Python runs and pythonfmu's binary is open */
    SEARCH_NO_PYTHON,   /* no Python qualifies (or one started without the packages) */
    SEARCH_BAD_BINARY   /* pythonfmu's binary cannot be opened or lacks FMI functions */
} SearchState;
static SearchState python_state = SEARCH_PENDING;
static char tried[TEXT_MAX];
static char chosen[PATH_MAX + 128]; /* the Python used, for the log */
static void *pythonfmu;

static void append(char *text, const char *format, ...)
{
    size_t used = strlen(text);
    if (used + 1 >= TEXT_MAX)
        return;
    va_list args;
    va_start(args, format);
    vsnprintf(text + used, TEXT_MAX - used, format, args);
    va_end(args);
}

/* The record's values of key (one per line, "key<TAB>value"), joined by sep into out. */
static int record_values(const char *resources, const char *key, char sep, char *out, size_t n)
{
    char path[PATH_MAX], line[PATH_MAX + 64];
    size_t klen = strlen(key), used = 0;
    int found = 0;
    snprintf(path, sizeof path, "%s/%s", resources, RECORD_FILE);
    FILE *file = fopen(path, "r");
    out[0] = '\0';
    if (!file)
        return 0;
    while (fgets(line, sizeof line, file)) {
        line[strcspn(line, "\r\n")] = '\0';
        if (strncmp(line, key, klen) == 0 && line[klen] == '\t' && line[klen + 1]) {
            char separator[2] = {found ? sep : '\0', '\0'};
            int w = snprintf(out + used, n - used, "%s%s", separator, line + klen + 1);
            if (w < 0 || (size_t)w >= n - used)
                break;
            used += (size_t)w;
            found = 1;
        }
    }
    fclose(file);
    return found;
}

/* What a candidate executable says about itself. */
typedef struct {
    long hexversion;
    char libpython[PATH_MAX];
    char missing[512];
} Probe;


/* Run "exe -c PROBE packages...": 1 when it answered (Probe filled), 0 when it did not run. */
static int probe(const char *exe, const char *packages, Probe *p)
{
    char list[512], *args[40];
    int fds[2], n = 0, status = 0;
    snprintf(list, sizeof list, "%s", packages);
    args[n++] = (char *)exe;
    args[n++] = "-c";
    args[n++] = (char *)PROBE;
    char *save = NULL; /* strtok_r: the host's own strtok state is left alone */
    for (char *tok = strtok_r(list, " ", &save); tok && n < 38; tok = strtok_r(NULL, " ", &save))
        args[n++] = tok;
    args[n] = NULL;
    if (pipe(fds) != 0)
        return 0;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", 0, 0);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    pid_t pid;
    int spawned = posix_spawn(&pid, exe, &actions, NULL, args, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (spawned != 0) {
        close(fds[0]);
        return 0;
    }
    char out[PATH_MAX + 1024];
    size_t used = 0;
    ssize_t got;
    while (used + 1 < sizeof out && (got = read(fds[0], out + used, sizeof out - 1 - used)) > 0)
        used += (size_t)got;
    out[used] = '\0';
    close(fds[0]);
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
        ;
    char *line2 = strchr(out, '\n');
    char *line3 = line2 ? strchr(line2 + 1, '\n') : NULL;
    if (!line3)
        return 0;
    *line2++ = '\0';
    *line3++ = '\0';
    line3[strcspn(line3, "\n")] = '\0';
    p->hexversion = strtol(out, NULL, 10);
    snprintf(p->libpython, sizeof p->libpython, "%s", line2);
    snprintf(p->missing, sizeof p->missing, "%s", line3);
    return 1;
}

/* Load libpython globally and start it (program: its executable, or NULL). */
static int start_python(const char *libpython, const char *program)
{
    void *lib = dlopen(libpython, RTLD_NOW | RTLD_GLOBAL);
    if (!lib) {
        append(tried, " (cannot load %s: %s)", libpython, dlerror());
        return 0;
    }
    int (*is_initialized)(void) = (int (*)(void))dlsym(lib, "Py_IsInitialized");
    void (*initialize)(int) = (void (*)(int))dlsym(lib, "Py_InitializeEx");
    void *(*save_thread)(void) = (void *(*)(void))dlsym(lib, "PyEval_SaveThread");
    if (!is_initialized || !initialize || !save_thread) {
        append(tried, " (%s is not a CPython library)", libpython);
        return 0;
    }
    if (!is_initialized()) {
        wchar_t *(*decode)(const char *, size_t *) =
            (wchar_t * (*)(const char *, size_t *)) dlsym(lib, "Py_DecodeLocale");
        void (*set_program)(const wchar_t *) =
            (void (*)(const wchar_t *))dlsym(lib, "Py_SetProgramName");
        if (program && decode && set_program) {
            static wchar_t *name; /* must outlive the interpreter */
            name = decode(program, NULL);
            if (name)
                set_program(name);
        }
        initialize(0); /* no signal handlers: the host owns them */
        save_thread(); /* release the GIL: pythonfmu takes it per call */
    }
    return 1;
}

/* The packages missing in the started interpreter (the libpython without executable). */
static int import_missing(const char *packages, char *missing, size_t n)
{
    int (*ensure)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "PyGILState_Ensure");
    void (*release)(int) = (void (*)(int))dlsym(RTLD_DEFAULT, "PyGILState_Release");
    void *(*import)(const char *) = (void *(*)(const char *))dlsym(RTLD_DEFAULT,
                                                                     "PyImport_ImportModule");
    void (*clear)(void) = (void (*)(void))dlsym(RTLD_DEFAULT, "PyErr_Clear");
    char list[512];
    missing[0] = '\0';
    if (!ensure || !release || !import || !clear)
        return 0;
    snprintf(list, sizeof list, "%s", packages);
    int gil = ensure();
    char *save = NULL;
    for (char *tok = strtok_r(list, " ", &save); tok; tok = strtok_r(NULL, " ", &save)) {
        if (!import(tok)) {
            clear();
            snprintf(missing + strlen(missing), n - strlen(missing), "%s%s",
                     missing[0] ? " " : "", tok);
        }
    }
    release(gil);
    return missing[0] != '\0';
}

static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Try the executable exe (found by: how); 1 when Python is now running. */
static int try_executable(const char *how, const char *exe, const char *packages)
{
    Probe p;
    append(tried, "; %s%s: ", how, exe);
    if (!is_file(exe) || access(exe, X_OK) != 0) {
        append(tried, "not found");
        return 0;
    }
    if (!probe(exe, packages, &p)) {
        append(tried, "does not run");
        return 0;
    }
    append(tried, "Python %ld.%ld", (p.hexversion >> 24) & 0xff, (p.hexversion >> 16) & 0xff);
    if (p.hexversion < MIN_HEXVERSION) {
        append(tried, ", older than 3.11");
        return 0;
    }
    if (!p.libpython[0]) {
        append(tried, ", no shared libpython (a --enable-shared build, or Debian's libpython3.x)");
        return 0;
    }
    if (p.missing[0]) {
        append(tried, ", without %s", p.missing);
        return 0;
    }
    if (!start_python(p.libpython, exe))
        return 0;
    append(tried, ": used");
    snprintf(chosen, sizeof chosen, "Python %ld.%ld, %s%s", (p.hexversion >> 24) & 0xff,
             (p.hexversion >> 16) & 0xff, how, exe);
    return 1;
}

/* python3 on PATH, into out. */
static int on_path(char *out, size_t n)
{
    const char *path = getenv("PATH");
    char copy[TEXT_MAX];
    snprintf(copy, sizeof copy, "%s", path ? path : "");
    char *save = NULL;
    for (char *dir = strtok_r(copy, ":", &save); dir; dir = strtok_r(NULL, ":", &save)) {
        snprintf(out, n, "%s/python3", *dir ? dir : ".");
        if (is_file(out) && access(out, X_OK) == 0)
            return 1;
    }
    return 0;
}

static int try_system_libpython(const char *packages)
{
    const char *const *names = SYSTEM_LIBPYTHONS;
    append(tried, "; the system's libpython: ");
    for (size_t i = 0; i < sizeof SYSTEM_LIBPYTHONS / sizeof SYSTEM_LIBPYTHONS[0]; i++) {
        void *probe_lib = dlopen(names[i], RTLD_LAZY | RTLD_LOCAL);
        if (!probe_lib)
            continue;
        dlclose(probe_lib);
        append(tried, "%s", names[i]);
        if (!start_python(names[i], NULL))
            return 0;
        char missing[512];
        if (import_missing(packages, missing, sizeof missing)) {
            append(tried, " started, without %s", missing);
            python_state = SEARCH_NO_PYTHON; /* an interpreter cannot be taken back */
            return 0;
        }
        append(tried, ": used");
        snprintf(chosen, sizeof chosen, "the system's %s", names[i]);
        return 1;
    }
    append(tried, "none of");
    for (size_t i = 0; i < sizeof SYSTEM_LIBPYTHONS / sizeof SYSTEM_LIBPYTHONS[0]; i++)
        append(tried, "%s %s", i ? "," : "", SYSTEM_LIBPYTHONS[i]);
    append(tried, " found");
    return 0;
}

static int resolve_targets(void *library, char *missing, size_t n);

/* Steps 2-4 of the search (the host has no Python): 1 when a Python is now running. */
static int start_a_python(const char *packages)
{
    char exe[PATH_MAX];
    int found = 0;
    append(tried, "no Python in the host process");
    const char *setting = getenv(ENV_PYTHON);
    if (setting && *setting) {
        struct stat st;
        if (stat(setting, &st) == 0 && S_ISDIR(st.st_mode))
            snprintf(exe, sizeof exe, "%s/bin/python3", setting);
        else
            snprintf(exe, sizeof exe, "%s", setting);
        found = try_executable(ENV_PYTHON "=", exe, packages);
    } else {
        append(tried, "; " ENV_PYTHON " not set");
    }
    if (!found && python_state == SEARCH_PENDING) {
        if (on_path(exe, sizeof exe))
            found = try_executable("python3 on PATH: ", exe, packages);
        else
            append(tried, "; no python3 on PATH");
    }
    if (!found && python_state == SEARCH_PENDING)
        found = try_system_libpython(packages);
    return found;
}

/* Open pythonfmu's binary next to this library and resolve its functions: the final state. */
static SearchState open_pythonfmu(void)
{
    char target[PATH_MAX], missing[TEXT_MAX / 2];
    Dl_info self;
    if (!dladdr((void *)&open_pythonfmu, &self) || !self.dli_fname) {
        append(tried, "; cannot locate this library");
        return SEARCH_BAD_BINARY;
    }
    const char *slash = strrchr(self.dli_fname, '/');
    int folder = slash ? (int)(slash + 1 - self.dli_fname) : 0;
    snprintf(target, sizeof target, "%.*s%s", folder, self.dli_fname, SMEHA_TARGET);
    pythonfmu = dlopen(target, RTLD_NOW | RTLD_LOCAL);
    if (!pythonfmu) {
        append(tried, "; cannot load pythonfmu's binary: %s", dlerror());
        return SEARCH_BAD_BINARY;
    }
    if (resolve_targets(pythonfmu, missing, sizeof missing) > 0) {
        append(tried, "; pythonfmu's binary %s lacks %s", target, missing);
        return SEARCH_BAD_BINARY;
    }
    /* pythonfmu frees its interpreter state from a static destructor and again from its
     * library destructor; its finalizePythonInterpreter, run first, leaves both a null
     * pointer (smeha_fmu_runtime.arm_clean_exit) */
    void (*finalize)(void) = (void (*)(void))dlsym(pythonfmu, "finalizePythonInterpreter");
    if (finalize)
        atexit(finalize);
    /* this library stays loaded: pythonfmu's instances call its relays */
    dlopen(self.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    return SEARCH_READY;
}

/* Find and start a Python, open pythonfmu's binary: 1 when ready (see the top of the file). */
static int ensure_python(const char *resources)
{
    pthread_mutex_lock(&search_lock);
    if (python_state == SEARCH_PENDING) {
        char packages[512];
        tried[0] = '\0';
        record_values(resources, "required", ' ', packages, sizeof packages);
        int (*is_initialized)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsInitialized");
        int found = 0;
        if (is_initialized && is_initialized()) {
            found = 1; /* the host's own Python; its packages are the slave's concern */
            snprintf(chosen, sizeof chosen, "the host process's Python");
        } else {
            found = start_a_python(packages);
        }
        /* without a Python the search may be tried again (SMEHA_FMU_PYTHON set since) */
        if (found)
            python_state = open_pythonfmu();
    }
    int ready = python_state == SEARCH_READY;
    pthread_mutex_unlock(&search_lock);
    return ready;
}

static void no_python_message(char *out, size_t n, const char *resources)
{
    char packages[512];
    record_values(resources, "required", ' ', packages, sizeof packages);
    if (python_state == SEARCH_BAD_BINARY) {
        snprintf(out, n, "%s: a Python runs, but pythonfmu's binary is unusable: %s", SMEHA_MODEL,
                 tried);
        return;
    }
    snprintf(out, n,
             "%s: no usable Python: the FMU needs CPython >= 3.11 with a shared libpython%s%s. "
             "Tried: %s. Point the FMU at a Python: set " ENV_PYTHON
             " to a python3 executable (or the prefix holding bin/python3) that has them "
             "(pip install %s; docs/FMU.md)",
             SMEHA_MODEL, packages[0] ? " and " : "", packages, tried,
             packages[0] ? packages : "numpy");
}

/* The resources folder from FMI 2.0's file URI or FMI 3.0's path (no trailing slash). */
static void resources_folder(const char *location, char *out, size_t n)
{
    const char *p = location ? location : "";
    if (strncmp(p, "file://", 7) == 0) {
        p += 7;
        if (strncmp(p, "localhost/", 10) == 0)
            p += 9;
    } else if (strncmp(p, "file:", 5) == 0) {
        p += 5;
    }
    size_t j = 0;
    for (size_t i = 0; p[i] && j + 1 < n; i++) { /* percent-decoding */
        if (p[i] == '%' && p[i + 1] && p[i + 2]) {
            char hex[3] = {p[i + 1], p[i + 2], 0};
            out[j++] = (char)strtol(hex, NULL, 16);
            i += 2;
        } else {
            out[j++] = p[i];
        }
    }
    out[j] = '\0';
    while (j > 1 && out[j - 1] == '/')
        out[--j] = '\0';
}

#include "smeha_fmu_forward.h"

#if SMEHA_FMI == 2
/* ---- FMI 2.0 -------------------------------------------------------------------------- */
static void relay_log(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status,
                      fmi2String category, fmi2String message, ...)
{
    Instance *in = environment;
    char text[TEXT_MAX];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message ? message : "", args);
    va_end(args);
    if (relay_message(in, status, category) && in->host.logger)
        in->host.logger(in->host.componentEnvironment, name, status, category, "%s", text);
}

static void relay_step_finished(fmi2ComponentEnvironment environment, fmi2Status status)
{
    Instance *in = environment;
    if (in->host.stepFinished)
        in->host.stepFinished(in->host.componentEnvironment, status);
}

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                          fmi2String location,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean logging_on)
{
    char resources[PATH_MAX];
    resources_folder(location, resources, sizeof resources);
    if (!functions)
        return NULL;
    if (!ensure_python(resources) || !T_fmi2Instantiate) {
        char message[TEXT_MAX];
        no_python_message(message, sizeof message, resources);
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error,
                              "logStatusError", "%s", message);
        else
            fprintf(stderr, "%s\n", message);
        return NULL;
    }
    Instance *in = calloc(1, sizeof *in);
    if (!in)
        return NULL;
    in->host = *functions;
    in->relay = *functions;
    in->relay.componentEnvironment = in;
    in->relay.logger = relay_log;
    in->relay.stepFinished = relay_step_finished;
    in->logging_on = logging_on;
    in->target = T_fmi2Instantiate(name, type, guid, location, &in->relay, visible, fmi2True);
    if (!in->target) {
        free(in);
        return NULL;
    }
    if (logging_on && functions->logger)
        functions->logger(functions->componentEnvironment, name, fmi2OK, "logAll",
                          "%s runs in %s", SMEHA_MODEL, chosen);
    return in;
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean logging_on,
                                           size_t n_categories, const fmi2String categories[])
{
    return set_debug_logging(c, logging_on, n_categories, categories);
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) { free_instance(c, T_fmi2FreeInstance); }

#else
/* ---- FMI 3.0 -------------------------------------------------------------------------- */
static void relay_log(fmi3InstanceEnvironment environment, fmi3Status status,
                      fmi3String category, fmi3String message)
{
    Instance *in = environment;
    if (relay_message(in, status, category) && in->host_log)
        in->host_log(in->host_environment, status, category, message);
}

static void relay_update(fmi3InstanceEnvironment environment, fmi3Float64 time,
                         fmi3Boolean set_requested, fmi3Boolean get_allowed,
                         fmi3Boolean step_finished, fmi3Boolean can_return_early,
                         fmi3Boolean *early_return_requested, fmi3Float64 *early_return_time)
{
    Instance *in = environment;
    if (in->host_update)
        in->host_update(in->host_environment, time, set_requested, get_allowed, step_finished,
                        can_return_early, early_return_requested, early_return_time);
}

FMI3_Export const char *fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String name, fmi3String token, fmi3String resource_path, fmi3Boolean visible,
    fmi3Boolean logging_on, fmi3Boolean event_mode_used, fmi3Boolean early_return_allowed,
    const fmi3ValueReference required[], size_t n_required,
    fmi3InstanceEnvironment environment, fmi3LogMessageCallback log,
    fmi3IntermediateUpdateCallback update)
{
    char resources[PATH_MAX];
    resources_folder(resource_path, resources, sizeof resources);
    if (!ensure_python(resources) || !T_fmi3InstantiateCoSimulation) {
        char message[TEXT_MAX];
        no_python_message(message, sizeof message, resources);
        if (log)
            log(environment, fmi3Error, "logStatusError", message);
        else
            fprintf(stderr, "%s\n", message);
        return NULL;
    }
    Instance *in = calloc(1, sizeof *in);
    if (!in)
        return NULL;
    in->host_environment = environment;
    in->host_log = log;
    in->host_update = update;
    in->logging_on = logging_on;
    in->target = T_fmi3InstantiateCoSimulation(name, token, resource_path, visible, fmi3True,
                                               event_mode_used, early_return_allowed, required,
                                               n_required, in, relay_log,
                                               update ? relay_update : NULL);
    if (!in->target) {
        free(in);
        return NULL;
    }
    if (logging_on && log) {
        char message[sizeof chosen + 64];
        snprintf(message, sizeof message, "%s runs in %s", SMEHA_MODEL, chosen);
        log(environment, fmi3OK, "logAll", message);
    }
    return in;
}

static fmi3Instance only_co_simulation(fmi3InstanceEnvironment environment,
                                       fmi3LogMessageCallback log)
{
    if (log)
        log(environment, fmi3Error, "logStatusError",
            SMEHA_MODEL " is a co-simulation FMU only");
    return NULL;
}

FMI3_Export fmi3Instance fmi3InstantiateModelExchange(
    fmi3String name, fmi3String token, fmi3String resource_path, fmi3Boolean visible,
    fmi3Boolean logging_on, fmi3InstanceEnvironment environment, fmi3LogMessageCallback log)
{
    (void)name, (void)token, (void)resource_path, (void)visible, (void)logging_on;
    return only_co_simulation(environment, log);
}

FMI3_Export fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String name, fmi3String token, fmi3String resource_path, fmi3Boolean visible,
    fmi3Boolean logging_on, fmi3InstanceEnvironment environment, fmi3LogMessageCallback log,
    fmi3ClockUpdateCallback clock_update, fmi3LockPreemptionCallback lock,
    fmi3UnlockPreemptionCallback unlock)
{
    (void)name, (void)token, (void)resource_path, (void)visible, (void)logging_on;
    (void)clock_update, (void)lock, (void)unlock;
    return only_co_simulation(environment, log);
}

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean logging_on,
                                           size_t n_categories, const fmi3String categories[])
{
    return set_debug_logging(instance, logging_on, n_categories, categories);
}

FMI3_Export void fmi3FreeInstance(fmi3Instance instance)
{
    free_instance(instance, T_fmi3FreeInstance);
}
#endif
