/* cli_parallel.c - the command-line tool's parallel-for (model.h mdl_parallel_fn; model/ creates
 * no threads, STYLE.md Sec. 1): each call starts T-1 threads that take indices from an atomic
 * counter beside the calling thread, and joins them. Callers whose work items do not depend on
 * the thread that runs them get identical results for every thread count. */
#include "cli.h"

#include <pthread.h>
#include <stdatomic.h>


typedef struct job {
    atomic_int next;
    int n;
    mdl_parallel_body body;
    void *ctx;
} job;

typedef struct worker_arg {
    job *j;
    int worker;
} worker_arg;

static void run_worker(job *j, int worker)
{
    for (;;) {
        int i = atomic_fetch_add(&j->next, 1);
        if (i >= j->n)
            return;
        j->body(j->ctx, i, worker);
    }
}

static void *worker_main(void *arg)
{
    worker_arg *a = arg;
    run_worker(a->j, a->worker);
    return NULL;
}

void cli_parallel_for(void *ud, int n, mdl_parallel_body body, void *ctx)
{
    cli_pool *p = ud;
    job j = {.n = n, .body = body, .ctx = ctx};
    atomic_init(&j.next, 0);
    pthread_t tid[64];
    worker_arg args[64];
    int started = 0;
    for (int w = 1; w < p->threads && w < 64; w++) {
        args[w] = (worker_arg){&j, w};
        if (pthread_create(&tid[w], NULL, worker_main, &args[w]) != 0)
            break; /* fewer threads: the remaining work falls to those that run */
        started = w;
    }
    run_worker(&j, 0);
    for (int w = 1; w <= started; w++)
        pthread_join(tid[w], NULL);
}
