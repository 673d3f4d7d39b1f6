/* nats_cluster.h - a NATS cluster on loopback for a test or benchmark: N nats-server nodes (Debian's
 * nats-server 2.9), each with a client port, a WebSocket port (no TLS), a monitoring port and a
 * cluster port, routed to every other node. Every node started here is killed when the process
 * exits (atexit) or is stopped by SIGINT/SIGTERM/SIGALRM (meson's timeout), also after a failed
 * assertion; the daemon of a harness registered with nats_cluster_adopt too. The nodes also die
 * with this process however it ends (PR_SET_PDEATHSIG), as the daemon does (daemon_harness.c). */
#ifndef MESHSTEER_TESTS_NATS_CLUSTER_H
#define MESHSTEER_TESTS_NATS_CLUSTER_H

#include <sys/types.h>

#define NATS_NODES_MAX 4

typedef struct nats_node {
    pid_t pid;
    int port, ws_port, http_port, cluster_port;
    char url[64]; /* nats://127.0.0.1:port */
    char log[1200];
} nats_node;

typedef struct nats_cluster {
    int n;
    nats_node node[NATS_NODES_MAX];
    char dir[1024];
} nats_cluster;

/* The nats-server program: $NATS_SERVER, else /usr/sbin/nats-server; NULL when absent. */
const char *nats_server_path(void);
/* Starts n nodes (config and log files in dir) and waits until each has routes to all the others
 * (its /routez); exits 1 with the logs printed when they do not come up within 20 s. */
void nats_cluster_start(nats_cluster *c, int n, const char *dir);
/* Starts node i again on the same ports (after nats_cluster_kill); waits for its client port. */
void nats_cluster_restart(nats_cluster *c, int i);
/* SIGKILL to node i, and waits for it. */
void nats_cluster_kill(nats_cluster *c, int i);
void nats_cluster_stop(nats_cluster *c);
/* Kill pid (SIGKILL) too when the process exits early, unless it was reaped. */
void nats_cluster_adopt(pid_t pid);
/* Forget pid (it was reaped). */
void nats_cluster_disown(pid_t pid);
/* k distinct free loopback TCP ports: all bound at once, then released (so distinct from one
 * another; good enough against other cooperating tests). */
void nats_free_ports(int *ports, int k);

#endif
