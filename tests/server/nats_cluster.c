/* nats_cluster.c - nats-server nodes clustered on loopback (see nats_cluster.h). */
#include "nats_cluster.h"
#include "daemon_harness.h"
#include "test.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define CHILDREN_MAX 16
static volatile pid_t children[CHILDREN_MAX];

static void kill_children(void)
{
    for (int i = 0; i < CHILDREN_MAX; i++)
        if (children[i] > 0)
            kill(children[i], SIGKILL);
}

static void on_fatal_signal(int sig)
{
    kill_children(); /* kill() is async-signal-safe */
    signal(sig, SIG_DFL);
    raise(sig);
}

static void adopt(pid_t pid)
{
    static int hooked;
    if (!hooked) {
        hooked = 1;
        atexit(kill_children);
        signal(SIGINT, on_fatal_signal);
        signal(SIGTERM, on_fatal_signal);
        signal(SIGALRM, on_fatal_signal);
    }
    for (int i = 0; i < CHILDREN_MAX; i++)
        if (children[i] <= 0) {
            children[i] = pid;
            return;
        }
}

static void disown(pid_t pid)
{
    for (int i = 0; i < CHILDREN_MAX; i++)
        if (children[i] == pid)
            children[i] = 0;
}

void nats_cluster_adopt(pid_t pid) { adopt(pid); }
void nats_cluster_disown(pid_t pid) { disown(pid); }

const char *nats_server_path(void)
{
    const char *p = getenv("NATS_SERVER");
    if (!p || !*p)
        p = "/usr/sbin/nats-server";
    return access(p, X_OK) == 0 ? p : NULL;
}

void nats_free_ports(int *ports, int k)
{
    /* every socket stays bound until all k are chosen: a port released and asked for again can
     * come back (CI once gave node 1's websocket the port of node 2's cluster listener) */
    int fds[4 * NATS_NODES_MAX];
    ASSERT(k >= 1 && k <= (int)(sizeof fds / sizeof fds[0]));
    for (int i = 0; i < k; i++) {
        struct sockaddr_in sa = {.sin_family = AF_INET};
        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t len = sizeof sa;
        fds[i] = socket(AF_INET, SOCK_STREAM, 0);
        ASSERT(fds[i] >= 0);
        ASSERT_INT_EQ(bind(fds[i], (struct sockaddr *)&sa, sizeof sa), 0);
        ASSERT_INT_EQ(getsockname(fds[i], (struct sockaddr *)&sa, &len), 0);
        ports[i] = ntohs(sa.sin_port);
    }
    for (int i = 0; i < k; i++)
        close(fds[i]);
}

static int port_open(int port)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    int ok = connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0;
    close(fd);
    return ok;
}

static void msleep_(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static void print_logs(const nats_cluster *c)
{
    for (int i = 0; i < c->n; i++) {
        fprintf(stderr, "---- %s\n", c->node[i].log);
        FILE *f = fopen(c->node[i].log, "r");
        char line[512];
        while (f && fgets(line, sizeof line, f))
            fputs(line, stderr);
        if (f)
            fclose(f);
    }
}

static void spawn(nats_cluster *c, int i)
{
    const char *server = nats_server_path();
    ASSERT(server);
    char conf[1200];
    snprintf(conf, sizeof conf, "%s/node%d.conf", c->dir, i + 1);
    nats_node *nd = &c->node[i];
    pid_t pid = fork();
    ASSERT(pid >= 0);
    if (pid == 0) {
        /* dies with this process even when it ends without exit handlers (a sanitizer's abort) */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        /* a benchmark under SCHED_FIFO (bench_daemon ... fifo) must not hand it to the servers:
         * Go's runtime spins its idle threads, and two spinning FIFO servers starve the two cores */
        struct sched_param sp = {0};
        sched_setscheduler(0, SCHED_OTHER, &sp);
        int fd = open(nd->log, O_WRONLY | O_CREAT | O_APPEND, 0644);
        dup2(fd, 1);
        dup2(fd, 2);
        execl(server, server, "-c", conf, (char *)NULL);
        _exit(127);
    }
    nd->pid = pid;
    adopt(pid);
    for (int t = 0; t < 200 && !port_open(nd->port); t++)
        msleep_(50);
    if (!port_open(nd->port)) {
        print_logs(c);
        fprintf(stderr, "nats-server node %d did not listen on %d\n", i + 1, nd->port);
        exit(1);
    }
}

static int routes_of(const nats_node *nd)
{
    harness h = {.port = nd->http_port};
    char *body = NULL;
    int n = -1;
    if (harness_get(&h, "/routez", &body) == 200) {
        cJSON *j = cJSON_Parse(body);
        cJSON *r = j ? cJSON_GetObjectItem(j, "num_routes") : NULL;
        n = cJSON_IsNumber(r) ? r->valueint : -1;
        cJSON_Delete(j);
    }
    free(body);
    return n;
}

void nats_cluster_start(nats_cluster *c, int n, const char *dir)
{
    ASSERT(n >= 1 && n <= NATS_NODES_MAX);
    memset(c, 0, sizeof *c);
    c->n = n;
    snprintf(c->dir, sizeof c->dir, "%s", dir);
    int ports[4 * NATS_NODES_MAX];
    nats_free_ports(ports, 4 * n);
    for (int i = 0; i < n; i++) {
        nats_node *nd = &c->node[i];
        nd->port = ports[4 * i];
        nd->ws_port = ports[4 * i + 1];
        nd->http_port = ports[4 * i + 2];
        nd->cluster_port = ports[4 * i + 3];
        snprintf(nd->url, sizeof nd->url, "nats://127.0.0.1:%d", nd->port);
        snprintf(nd->log, sizeof nd->log, "%s/node%d.log", dir, i + 1);
    }
    for (int i = 0; i < n; i++) {
        nats_node *nd = &c->node[i];
        char conf[1200];
        snprintf(conf, sizeof conf, "%s/node%d.conf", dir, i + 1);
        FILE *f = fopen(conf, "w");
        ASSERT(f);
        fprintf(f,
                "server_name: node%d\nlisten: 127.0.0.1:%d\nhttp: 127.0.0.1:%d\n"
                "websocket { listen: \"127.0.0.1:%d\", no_tls: true }\n"
                "cluster {\n  name: meshsteer-test\n  listen: 127.0.0.1:%d\n  routes: [\n",
                i + 1, nd->port, nd->http_port, nd->ws_port, nd->cluster_port);
        for (int j = 0; j < n; j++)
            if (j != i)
                fprintf(f, "    nats-route://127.0.0.1:%d\n", c->node[j].cluster_port);
        fprintf(f, "  ]\n}\n");
        fclose(f);
    }
    for (int i = 0; i < n; i++)
        spawn(c, i);
    for (int t = 0; t < 400; t++) {
        int ok = 1;
        for (int i = 0; i < n && ok; i++)
            ok = routes_of(&c->node[i]) >= n - 1;
        if (ok)
            return;
        msleep_(50);
    }
    print_logs(c);
    fprintf(stderr, "the %d nats-server nodes did not form a cluster within 20 s\n", n);
    exit(1);
}

void nats_cluster_restart(nats_cluster *c, int i)
{
    ASSERT(c->node[i].pid <= 0);
    spawn(c, i);
}

void nats_cluster_kill(nats_cluster *c, int i)
{
    nats_node *nd = &c->node[i];
    if (nd->pid <= 0)
        return;
    kill(nd->pid, SIGKILL);
    waitpid(nd->pid, NULL, 0);
    disown(nd->pid);
    nd->pid = 0;
}

void nats_cluster_stop(nats_cluster *c)
{
    for (int i = 0; i < c->n; i++)
        nats_cluster_kill(c, i);
}
