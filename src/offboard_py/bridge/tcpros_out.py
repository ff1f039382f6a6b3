"""The bridge's outgoing TCPROS connections without a thread each: what roscpp does, in rospy.

rospy gives a publisher created with a queue_size one writer thread per subscriber connection
(`rospy.impl.tcpros_pubsub.QueuedConnection`): every message to every subscriber takes a lock, wakes
that thread and yields the caller's time slice (`time.sleep(0)`). For the bridge, which publishes
some 40 topics at up to 100 Hz from one receive thread, that wake-up per message per subscriber
was most of its cost with every topic subscribed (13.6 % of a core against real mavros's 5.7 % on
the same PX4 replay: bench/results/2026-11-25-mavros-side-by-side.md). Publishing without a queue
(queue_size=None) writes in the caller's thread but blocks it on a subscriber that stops reading.

`UnblockedConnection` takes the place of QueuedConnection, as roscpp's connections do: a message
is written at once, in the publishing thread, without blocking (MSG_DONTWAIT); what the kernel
cannot take (a subscriber that reads slowly or not at all) waits in that connection's queue of
queue_size messages, the oldest dropped first, as rospy's and roscpp's queues drop, and one
thread (`Flusher`) for all connections sends it when the socket can take it. A message is never
cut: a partly sent one is finished before the next.

rospy has no public hook for this: `install(publisher, queue_size)` replaces the wrapper at the one
place rospy chooses it (`_PublisherImpl.add_connection` wraps when its queue_size is set), and
leaves rospy's own queue in place when that place is not as rospy 1.15.15 (Debian 12) has it.
"""

import collections
import errno
import logging
import select
import socket
import threading

from rospy.exceptions import TransportTerminated
from rospy.impl.tcpros_pubsub import QueuedConnection

_log = logging.getLogger(__name__)

FLUSH_POLL_MS = 50  # how long the flusher waits for a socket before it looks for new backed-up ones


class Flusher:
    """One thread that sends what backed-up connections hold, started at the first one."""

    def __init__(self, poll_ms=FLUSH_POLL_MS):
        self.poll_ms = poll_ms
        self._cond = threading.Condition()
        self._backed_up = set()
        self._thread = None

    def backed_up(self, connection):
        """`connection` holds data the kernel would not take; called with its lock held."""
        with self._cond:
            self._backed_up.add(connection)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name='tcpros_flusher', daemon=True)
                self._thread.start()
            self._cond.notify()

    def _run(self):
        while True:
            with self._cond:
                while not self._backed_up:
                    self._cond.wait()
                connections = list(self._backed_up)
            poller = select.poll()
            by_fd = {}
            for connection in connections:
                fd = connection.socket_fd()
                if fd >= 0:
                    by_fd[fd] = connection
                    poller.register(fd, select.POLLOUT)
            ready = poller.poll(self.poll_ms) if by_fd else ()
            for fd, _events in ready:
                try:
                    by_fd[fd].flush()
                except Exception:  # this thread serves every backed-up subscriber: it must outlive one
                    _log.exception('subscriber %s: sending what waited failed; closing the connection',
                                   by_fd[fd].endpoint_id)
                    by_fd[fd].close()
            for connection in connections:
                connection.forget_if_idle(self._forget)

    def _forget(self, connection):
        """Called with `connection`'s lock held, so that a write cannot slip between look and forget."""
        with self._cond:
            self._backed_up.discard(connection)


class UnblockedConnection:
    """A publisher's TCPROS transport that never blocks the publishing thread (see the module doc).

    Behaves as the transport for everything else (rospy reads its endpoint_id, fileno, stats and
    cleanup callback through it, as through QueuedConnection)."""

    def __init__(self, connection, queue_size, flusher):
        """`queue_size`: messages held for a subscriber the kernel's buffer is full for; 0 is no limit."""
        self._connection = connection
        self._socket = connection.socket
        self._queue_size = queue_size
        self._flusher = flusher
        self._lock = threading.Lock()
        self._pending = collections.deque()  # messages not yet sent, oldest first
        self._head_sent = 0  # bytes of the oldest pending message already sent
        self.dropped = 0  # messages dropped because the queue was full

    def __getattr__(self, name):
        if name.startswith('__'):
            raise AttributeError(name)
        return getattr(self._connection, name)

    def write_data(self, data):
        with self._lock:
            if self._connection.done:
                raise TransportTerminated('connection closed')
            if self._pending:
                self._enqueue(data)
                return True
            sent = self._send(data)
            if sent < len(data):
                self._pending.append(data)
                self._head_sent = sent
                self._flusher.backed_up(self)
        return True

    def flush(self):
        """Send what is pending until the kernel takes no more (the flusher's thread)."""
        with self._lock:
            try:
                while self._pending and not self._connection.done:
                    data = self._pending[0]
                    sent = self._send(memoryview(data)[self._head_sent:])
                    self._head_sent += sent
                    if self._head_sent < len(data):
                        return
                    self._pending.popleft()
                    self._head_sent = 0
            except TransportTerminated:
                self._pending.clear()

    def socket_fd(self):
        """The socket's descriptor, -1 once closed."""
        return -1 if self._connection.done else self._socket.fileno()

    def forget_if_idle(self, forget):
        with self._lock:
            if not self._pending or self._connection.done:
                self._pending.clear()
                forget(self)

    def _enqueue(self, data):
        # a partly sent message stays: the subscriber has its first bytes and must get the rest
        partial = 1 if self._head_sent else 0
        if self._queue_size > 0 and len(self._pending) - partial >= self._queue_size:
            del self._pending[partial]
            self.dropped += 1
        self._pending.append(data)

    def _send(self, data):
        """Bytes of `data` the kernel took now (0 if none); counts a message once its last byte is
        out. A dead connection is closed (rospy then drops it from the topic) and raises
        TransportTerminated, as rospy's transport does on a broken pipe."""
        try:
            sent = self._socket.send(data, socket.MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError as err:
            _log.debug('subscriber %s: %s', self._connection.endpoint_id, err)
            self._connection.close()
            raise TransportTerminated('%s: %s' % (errno.errorcode.get(err.errno, err.errno), err)) from err
        self._connection.stat_bytes += sent
        if sent == len(data):
            self._connection.stat_num_msg += 1
        return sent


def install(publisher, queue_size, flusher):
    """Give `publisher`'s future subscriber connections an UnblockedConnection holding `queue_size`
    messages instead of rospy's QueuedConnection. Publishers of one topic in one process share
    rospy's topic object; each call sets it again, as rospy's own constructor does. Returns False
    (rospy's queue stays) where rospy's publisher is not shaped as this expects."""
    impl = getattr(publisher, 'impl', None)
    add_connection = getattr(type(impl), 'add_connection', None)
    if add_connection is None or not hasattr(impl, 'queue_size'):
        _log.warning('rospy publisher %s: no add_connection to hook: rospy\'s per-connection threads stay',
                     getattr(publisher, 'name', publisher))
        return False

    def add_unblocked_connection(connection):
        sock = getattr(connection, 'socket', None)
        # not a socket, or one with a timeout (Python then waits for room before it sends, whatever the
        # flags): as rospy would
        if sock is None or sock.gettimeout() is not None:
            return add_connection(impl, QueuedConnection(connection, queue_size))
        return add_connection(impl, UnblockedConnection(connection, queue_size, flusher))

    impl.queue_size = None  # rospy wraps no more: the connection comes wrapped
    impl.add_connection = add_unblocked_connection
    return True
