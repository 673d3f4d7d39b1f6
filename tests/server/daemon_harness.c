/* daemon_harness.c - see daemon_harness.h. */
#include "daemon_harness.h"
#include "test.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static void msleep(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *b = malloc(cap + 1);
    size_t got;
    while ((got = fread(b + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap)
            b = realloc(b, (cap *= 2) + 1);
    }
    fclose(f);
    b[n] = '\0';
    return b;
}

void harness_copy(const char *from, const char *to)
{
    FILE *a = fopen(from, "rb");
    ASSERT(a);
    char tmp[1200];
    snprintf(tmp, sizeof tmp, "%s.tmp", to);
    FILE *b = fopen(tmp, "wb");
    ASSERT(b);
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, a)) > 0)
        ASSERT(fwrite(buf, 1, n, b) == n);
    fclose(a);
    ASSERT(fclose(b) == 0);
    ASSERT(rename(tmp, to) == 0); /* atomic, as a deploy would do */
}

void harness_dir(harness *h)
{
    const char *build = getenv("MESHSTEER_BUILD");
    snprintf(h->dir, sizeof h->dir, "%s/tests/server/tmp-XXXXXX", build ? build : "/tmp");
    ASSERT(mkdtemp(h->dir));
}

char *harness_read(const char *path, char *buf, size_t cap)
{
    FILE *f = fopen(path, "r");
    ASSERT(f);
    size_t got = fread(buf, 1, cap - 1, f);
    fclose(f);
    buf[got] = '\0';
    return buf;
}

pid_t harness_spawn(const char *const *argv, const char *out_path)
{
    pid_t pid = fork();
    ASSERT(pid >= 0);
    if (pid == 0) {
        int fd = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(fd, 1);
        dup2(fd, 2);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    return pid;
}

int harness_wait(pid_t pid)
{
    int st;
    ASSERT(waitpid(pid, &st, 0) == pid);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

int harness_run(const char *const *argv, const char *out_path)
{
    return harness_wait(harness_spawn(argv, out_path));
}

void harness_fixtures(harness *h, const char *make_model)
{
    harness_dir(h);
    char cmd[2300];
    snprintf(cmd, sizeof cmd, "'%s' '%s' >/dev/null", make_model, h->dir);
    if (system(cmd) != 0) {
        fprintf(stderr, "make_model failed\n");
        exit(1);
    }
    char a[1100], b[1100];
    snprintf(a, sizeof a, "%s/example.msm", h->dir);
    snprintf(b, sizeof b, "%s/model.msm", h->dir);
    harness_copy(a, b);
}

int harness_log_has(const harness *h, const char *needle)
{
    char *s = slurp(h->log);
    int r = s && strstr(s, needle) != NULL;
    free(s);
    return r;
}

void harness_start(harness *h, const char *meshsteerd, const char *const *args)
{
    static int starts; /* a fresh log per start: the parent must not read the last one's port */
    snprintf(h->log, sizeof h->log, "%s/daemon-%d.log", h->dir, ++starts);
    unlink(h->log);
    const char *argv[64];
    int n = 0;
    argv[n++] = meshsteerd;
    for (int i = 0; args[i] && n < 62; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    h->pid = fork();
    ASSERT(h->pid >= 0);
    if (h->pid == 0) {
        /* the daemon dies with the test even when the test ends without exit handlers */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        int fd = open(h->log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(fd, 2);
        /* a later option wins; ignored by a daemon built without sanitizers */
        const char *a = getenv("ASAN_OPTIONS");
        char asan[1024];
        snprintf(asan, sizeof asan, "%s%squarantine_size_mb=1:thread_local_quarantine_size_kb=64",
                 a ? a : "", a && *a ? ":" : "");
        setenv("ASAN_OPTIONS", asan, 1);
        execv(meshsteerd, (char *const *)argv);
        _exit(127);
    }
    for (int t = 0; t < 300; t++) { /* up to 30 s: the model loads first */
        char *s = slurp(h->log);
        /* "listening on http://ADDR:PORT/", ADDR an IPv4 address or [IPv6] */
        const char *p = s ? strstr(s, "listening on http://") : NULL;
        const char *slash = p ? strchr(p + strlen("listening on http://"), '/') : NULL;
        const char *colon = slash ? memrchr(p, ':', (size_t)(slash - p)) : NULL;
        if (colon) {
            h->port = atoi(colon + 1);
            free(s);
            return;
        }
        free(s);
        int st;
        if (waitpid(h->pid, &st, WNOHANG) == h->pid) {
            s = slurp(h->log);
            fprintf(stderr, "meshsteerd exited early (status %d):\n%s\n", st, s ? s : "");
            exit(1);
        }
        msleep(100);
    }
    fprintf(stderr, "meshsteerd did not start listening\n");
    kill(h->pid, SIGKILL);
    exit(1);
}

int harness_get(const harness *h, const char *path, char **body)
{
    *body = NULL;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)h->port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa)) {
        close(fd);
        return -1;
    }
    char req[512], auth[128] = "";
    if (h->token[0])
        snprintf(auth, sizeof auth, "Authorization: Bearer %s\r\n", h->token);
    int n = snprintf(req, sizeof req,
                     "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\n%sConnection: close\r\n\r\n", path,
                     auth);
    ASSERT(write(fd, req, (size_t)n) == n);
    size_t cap = 1 << 16, len = 0;
    char *b = malloc(cap + 1);
    ssize_t got;
    while ((got = read(fd, b + len, cap - len)) > 0) {
        len += (size_t)got;
        if (len == cap)
            b = realloc(b, (cap *= 2) + 1);
    }
    close(fd);
    b[len] = '\0';
    int status = 0;
    if (sscanf(b, "HTTP/1.1 %d", &status) != 1) {
        free(b);
        return -1;
    }
    char *sep = strstr(b, "\r\n\r\n");
    *body = strdup(sep ? sep + 4 : "");
    free(b);
    return status;
}

int harness_raw(const harness *h, const char *request, size_t n, char **answer)
{
    *answer = NULL;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)h->port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct timeval tv = {5, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa)) {
        close(fd);
        return -1;
    }
    for (size_t off = 0; off < n;) {
        ssize_t w = send(fd, request + off, n - off, MSG_NOSIGNAL);
        if (w <= 0)
            break; /* the daemon may close before it has read everything */
        off += (size_t)w;
    }
    size_t cap = 1 << 16, len = 0;
    char *b = malloc(cap + 1);
    ssize_t got;
    while ((got = read(fd, b + len, cap - len)) > 0) {
        len += (size_t)got;
        if (len == cap)
            b = realloc(b, (cap *= 2) + 1);
    }
    close(fd);
    b[len] = '\0';
    *answer = b;
    if (len == 0)
        return -1;
    int status = 0;
    if (sscanf(b, "HTTP/1.1 %d", &status) != 1)
        return 0;
    return status;
}

double harness_metric(const harness *h, const char *sample)
{
    char *body;
    if (harness_get(h, "/metrics", &body) != 200) {
        free(body);
        return -1;
    }
    double v = -1;
    size_t n = strlen(sample);
    for (char *line = strtok(body, "\n"); line; line = strtok(NULL, "\n"))
        if (!strncmp(line, sample, n) && line[n] == ' ')
            v = atof(line + n + 1);
    free(body);
    return v;
}

int harness_metric_family(const harness *h, const char *prefix, double *v, int max)
{
    char *body;
    if (harness_get(h, "/metrics", &body) != 200) {
        free(body);
        return -1;
    }
    int n = 0;
    size_t np = strlen(prefix);
    for (char *line = strtok(body, "\n"); line; line = strtok(NULL, "\n")) {
        char *sp = strrchr(line, ' ');
        if (!strncmp(line, prefix, np) && line[np] == '{' && sp && n < max)
            v[n++] = atof(sp + 1);
    }
    free(body);
    return n;
}

int harness_stop(harness *h, int sig, int timeout_ms)
{
    kill(h->pid, sig);
    for (int t = 0; t < timeout_ms / 10; t++) {
        int st;
        if (waitpid(h->pid, &st, WNOHANG) == h->pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        msleep(10);
    }
    kill(h->pid, SIGKILL);
    waitpid(h->pid, NULL, 0);
    return -1;
}

int harness_stalled_client(const harness *h)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    int small = 4096;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)h->port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT(connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0);
    const char *req = "GET /stream HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                      "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                      "Sec-WebSocket-Version: 13\r\n\r\n";
    ASSERT(write(fd, req, strlen(req)) == (ssize_t)strlen(req));
    return fd;
}

long harness_rss_kb(const harness *h)
{
    char path[64];
    snprintf(path, sizeof path, "/proc/%d/status", (int)h->pid);
    char *s = slurp(path);
    const char *p = s ? strstr(s, "VmRSS:") : NULL;
    long kb = p ? atol(p + 6) : -1;
    free(s);
    return kb;
}
