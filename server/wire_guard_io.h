/* wire_guard_io.h - puts wire_guard.c between meshsteerd's client sockets and libwebsockets 4.1.
 *
 * libwebsockets.so reads a plain (non-TLS) connection with recv() (lws_ssl_capable_read_no_ssl,
 * lib/core-net/output.c) and closes it with close(), both imported from libc by name. meshsteerd
 * defines recv and close itself (wire_guard_io.c); the dynamic linker binds lws's references to
 * the executable's definitions, which call the next ones (libc's, or a sanitizer's interceptor)
 * through dlsym(RTLD_NEXT). A socket registered here (lws accepted it) has each byte it receives
 * fed to a srv_guard before lws gets it; every other descriptor (NATS, drivers, files) passes
 * through at the cost of one load of an atomic flag. A registered socket leaves the table in
 * close(), before its number can be reused.
 *
 * Verdicts (wire_guard.h):
 *  - HTTP (400, 414, 431, 501): lws gets the bytes before the deciding one. When every earlier
 *    request on the connection has been answered and lws holds no unsent output for it, the
 *    guard sends the short response itself (send, MSG_NOSIGNAL), shuts the socket's sending side
 *    and returns 0 (end of stream) to lws, which closes it. Otherwise (requests pipelined before
 *    the bad one still being answered) http.c answers it when the last of them is done
 *    (srv_guard_io_answered), or, when lws still holds output then, the connection is closed
 *    unanswered.
 *  - unmasked frame: lws gets the bytes before its second byte (the one with the mask bit), the
 *    daemon is woken (srv_guard_io_start's wake), and proto_stream.c closes the session with
 *    1002 (srv_guard_io_verdict). Until then further bytes are dropped; once the close is under
 *    way (srv_guard_io_closing) a read returns end of stream, so lws does not wait for the
 *    client's close frame.
 * Threads: registration, verdicts and the per-socket state belong to the lws service thread
 * (recv on a registered socket only happens there); any thread may call recv and close. */
#ifndef MESHSTEER_SERVER_WIRE_GUARD_IO_H
#define MESHSTEER_SERVER_WIRE_GUARD_IO_H

#include <libwebsockets.h>

/* Sizes the table for descriptors below RLIMIT_NOFILE (at most 1 << 20) and learns lws's header
 * names. wake(ud) is called, on the service thread, when a session must be closed. 0 or -ENOMEM
 * (err says so). Call before lws creates its context. */
int srv_guard_io_start(uint32_t max_head, void (*wake)(void *), void *ud, char *err);
void srv_guard_io_stop(void);

/* lws accepted wsi (LWS_CALLBACK_SERVER_NEW_CLIENT_INSTANTIATED): guard its socket. 0, or -EMFILE
 * when its number is beyond the table (the caller refuses the connection). */
int srv_guard_io_open(struct lws *wsi);

/* http.c finished a response on wsi. Returns 1 when the connection must close now (a refused
 * request follows: answered here if lws holds no unsent output, else not), 0 to go on. */
int srv_guard_io_answered(struct lws *wsi);

/* lws hands wsi's request to http.c (LWS_CALLBACK_HTTP): if the guard took it for a WebSocket
 * upgrade, it reads the next request instead. Returns -1 when the connection must close (it had
 * already read bytes after that request as frames), else 0. */
int srv_guard_io_http(struct lws *wsi);

/* The verdict of wsi's connection (SRV_GUARD_*), 0 when none. */
int srv_guard_io_verdict(struct lws *wsi);

/* proto_stream.c is closing wsi for its verdict: later reads return end of stream. */
void srv_guard_io_closing(struct lws *wsi);

#endif
