/*
 * libpg_loopback_bind.so: an LD_PRELOAD shim that keeps "all interfaces" servers on loopback.
 *
 * Contract:
 *   - Active only while the environment variable PG_LOOPBACK_BIND is exactly "1" (read at each bind(2) call). Any
 *     other value, or none, and every bind(2) goes to the C library unchanged: a process that inherits LD_PRELOAD
 *     but runs with PG_LOOPBACK_BIND unset (the robot-network mode of scripts/ros_env.sh) binds as it asks.
 *   - Only binds that libxmlrpcpp makes are touched (the caller's shared object, from dladdr of the return address,
 *     is a libxmlrpcpp): every other program of a shell that sourced ros_env.sh (Python, Ray, a Jupyter server)
 *     binds as it asks.
 *   - When active, such a bind(2) of a TCP or UDP socket to the wildcard address binds to loopback instead, same port:
 *       AF_INET  0.0.0.0 (INADDR_ANY)   -> 127.0.0.1
 *       AF_INET6 ::      (in6addr_any) -> ::1 (a dual-stack socket then accepts ::1 only, not 127.0.0.1)
 *     Every other bind(2) passes through unchanged: a specific address, another family (AF_UNIX, AF_NETLINK, ...),
 *     another protocol (raw, SCTP, ...), a socket whose type cannot be read, a short address.
 *   - The caller's sockaddr is never written to; the result and errno are those of the real bind(2).
 *
 * Why: scripts/ros_env.sh's loopback mode (ROS_HOSTNAME=localhost) puts every ROS port on 127.0.0.1 but one, the
 * XML-RPC port of each roscpp node, which xmlrpcpp's XmlRpcSocket::bind always binds to INADDR_ANY. ros_env.sh
 * preloads this library with PG_LOOPBACK_BIND=1 in that mode only.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

typedef int (*bind_fn)(int, const struct sockaddr *, socklen_t);

/* The C library's bind(2), resolved on first use (a race resolves it twice, to the same value). */
static bind_fn next_bind(void) {
  static bind_fn real;
  bind_fn fn = __atomic_load_n(&real, __ATOMIC_ACQUIRE);
  if (fn == NULL) {
    void *sym = dlsym(RTLD_NEXT, "bind");
    memcpy(&fn, &sym, sizeof fn); /* ISO C has no object-to-function pointer cast; POSIX makes this one valid */
    __atomic_store_n(&real, fn, __ATOMIC_RELEASE);
  }
  return fn;
}

static int enabled(void) {
  const char *v = getenv("PG_LOOPBACK_BIND");
  return v != NULL && strcmp(v, "1") == 0;
}

/* 1 when the code at `caller` lies in libxmlrpcpp (the one library that binds INADDR_ANY whatever ROS says). */
static int from_xmlrpcpp(const void *caller) {
  Dl_info info;
  return caller != NULL && dladdr(caller, &info) != 0 && info.dli_fname != NULL &&
         strstr(info.dli_fname, "libxmlrpcpp") != NULL;
}

/* 1 when fd is a TCP or UDP socket (errno is left as it was). */
static int is_tcp_or_udp(int fd) {
  int saved = errno;
  int proto = 0;
  socklen_t len = sizeof proto;
  int ok = getsockopt(fd, SOL_SOCKET, SO_PROTOCOL, &proto, &len) == 0;
  errno = saved;
  return ok && (proto == IPPROTO_TCP || proto == IPPROTO_UDP);
}

int bind(int fd, const struct sockaddr *addr, socklen_t len) {
  bind_fn real = next_bind();
  if (real == NULL) {
    errno = ENOSYS;
    return -1;
  }
  if (addr == NULL || !enabled() || !from_xmlrpcpp(__builtin_return_address(0))) return real(fd, addr, len);

  if (addr->sa_family == AF_INET && len >= (socklen_t)sizeof(struct sockaddr_in)) {
    struct sockaddr_in in4;
    memcpy(&in4, addr, sizeof in4);
    if (in4.sin_addr.s_addr == htonl(INADDR_ANY) && is_tcp_or_udp(fd)) {
      in4.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      return real(fd, (const struct sockaddr *)&in4, (socklen_t)sizeof in4);
    }
  } else if (addr->sa_family == AF_INET6 && len >= (socklen_t)sizeof(struct sockaddr_in6)) {
    struct sockaddr_in6 in6;
    memcpy(&in6, addr, sizeof in6);
    if (memcmp(&in6.sin6_addr, &in6addr_any, sizeof in6addr_any) == 0 && is_tcp_or_udp(fd)) {
      in6.sin6_addr = in6addr_loopback;
      return real(fd, (const struct sockaddr *)&in6, (socklen_t)sizeof in6);
    }
  }
  return real(fd, addr, len);
}
