"""Outgoing TCPROS connections without a thread each (the bridge's topics, /clock), as roscpp writes.

rospy gives a publisher created with a queue_size one writer thread per subscriber connection
(`rospy.impl.tcpros_pubsub.QueuedConnection`): every message to every subscriber takes a lock, wakes
that thread and yields the caller's time slice (`time.sleep(0)`). For the bridge, which publishes
some 40 topics at up to 100 Hz from one receive thread, that wake-up per message per subscriber
was most of its cost with every topic subscribed (13.6 % of a core against real mavros's 5.7 % on
the same PX4 replay: bench/results/2026-11-25-mavros-side-by-side.md). Publishing without a queue
(queue_size=None) writes in the caller's thread but blocks it on a subscriber that stops reading.

`Publisher` is the package's own publisher, which the bridge's plugins and the /clock node call:
rospy's Publisher (made without a queue, so rospy hands over its subscribers' transports as they are)
registers the topic, accepts the subscribers and sends a latched topic's last message to a new one;
`Publisher.publish` serialises a message once, as rospy does, and writes it to each subscriber through
an `UnblockedConnection` of its own, as roscpp's connections write: at once, in the publishing thread, without blocking
(MSG_DONTWAIT); what the kernel cannot take (a subscriber that reads slowly or not at all) waits in
that connection's queue of queue_size messages, the oldest dropped first, as rospy's and roscpp's
queues drop, and one thread (`Flusher`) for all connections sends it when the socket can take it. A
message is never cut: a partly sent one is finished before the next. Nothing of rospy is replaced:
rospy's own publishers (a user's, in another process or this one) stay as rospy makes them.
"""

import collections
import errno
import io
import logging
import select
import socket
import threading
import warnings

import genpy
import rospy
from rospy.exceptions import ROSSerializationException, TransportTerminated
from rospy.impl.tcpros_pubsub import QueuedConnection
from rospy.msg import serialize_message

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
                                   by_fd[fd].transport.endpoint_id)
                    by_fd[fd].transport.close()
            for connection in connections:
                connection.forget_if_idle(self._forget)

    def _forget(self, connection):
        """Called with `connection`'s lock held, so that a write cannot slip between look and forget."""
        with self._cond:
            self._backed_up.discard(connection)


class UnblockedConnection:
    """Writes one subscriber's TCPROS transport (`transport`) without ever blocking the publishing
    thread (see the module doc); the transport's stats count what it sent."""

    def __init__(self, connection, queue_size, flusher):
        """`queue_size`: messages held for a subscriber the kernel's buffer is full for; 0 is no limit."""
        self.transport = connection
        self._socket = connection.socket
        self._queue_size = queue_size
        self._flusher = flusher
        self._lock = threading.Lock()
        self._pending = collections.deque()  # messages not yet sent, oldest first
        self._head_sent = 0  # bytes of the oldest pending message already sent
        self.dropped = 0  # messages dropped because the queue was full

    def write_data(self, data):
        with self._lock:
            if self.transport.done:
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
                while self._pending and not self.transport.done:
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
        return -1 if self.transport.done else self._socket.fileno()

    def forget_if_idle(self, forget):
        with self._lock:
            if not self._pending or self.transport.done:
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
            _log.debug('subscriber %s: %s', self.transport.endpoint_id, err)
            self.transport.close()
            raise TransportTerminated('%s: %s' % (errno.errorcode.get(err.errno, err.errno), err)) from err
        self.transport.stat_bytes += sent
        if sent == len(data):
            self.transport.stat_num_msg += 1
        return sent


class Publisher:
    """A topic published through UnblockedConnections (see the module doc). Takes rospy.Publisher's
    arguments but for queue_size, which is each subscriber's queue here."""

    def __init__(self, name, data_class, queue_size, flusher, latch=False, subscriber_listener=None):
        """`queue_size`: messages held for a subscriber the kernel's buffer is full for; 0 is no limit."""
        with warnings.catch_warnings():
            # rospy advises a queue_size: the queue is this module's, one a subscriber
            warnings.simplefilter('ignore', SyntaxWarning)
            self.rospy_publisher = rospy.Publisher(name, data_class, queue_size=None, latch=latch,
                                                   subscriber_listener=subscriber_listener)
        self.name = self.rospy_publisher.name
        self.resolved_name = self.rospy_publisher.resolved_name
        self.queue_size = queue_size
        self._flusher = flusher
        self._buffer = io.BytesIO()
        self._seq = 0
        self._connections = []  # rospy's list of this topic's transports when the writers were made
        self._writers = []

    def get_num_connections(self):
        return self.rospy_publisher.get_num_connections()

    def unregister(self):
        self.rospy_publisher.unregister()

    def writers(self):
        """Each subscriber's writer now (an UnblockedConnection; rospy's QueuedConnection for a socket
        with a timeout, on which Python would wait for room whatever the flags)."""
        impl = self.rospy_publisher.impl
        if impl is None:
            return []
        connections = impl.connections  # rospy replaces the list when it adds or drops one
        if connections is not self._connections:
            kept = {id(writer.transport): writer for writer in self._writers}
            self._writers = [kept.get(id(connection)) or self._writer(connection) for connection in connections]
            self._connections = connections
        return self._writers

    def _writer(self, connection):
        sock = getattr(connection, 'socket', None)
        if sock is None or sock.gettimeout() is not None:
            writer = QueuedConnection(connection, self.queue_size)
            writer.transport = connection
            return writer
        return UnblockedConnection(connection, self.queue_size, self._flusher)

    def publish(self, message):
        """Write `message` to every subscriber now, never waiting for one; False when there is none.
        A latched topic keeps it for subscribers to come (rospy sends it to them)."""
        impl = self.rospy_publisher.impl
        if impl is None or impl.closed:
            if rospy.is_shutdown():
                return False
            raise rospy.ROSException('publish() to a closed topic %s' % self.resolved_name)
        dead = []
        impl.acquire()  # rospy's own lock for the topic: a new subscriber's latched message is not interleaved
        try:
            if impl.is_latch:
                impl.latch = message
            writers = self.writers()
            if not writers:
                return False
            self._seq += 1
            self._buffer.seek(0)
            self._buffer.truncate(0)
            try:
                serialize_message(self._buffer, self._seq, message)
            except genpy.SerializationError as err:
                raise ROSSerializationException('%s: %s' % (self.resolved_name, err)) from err
            data = self._buffer.getvalue()
            for writer in writers:
                try:
                    writer.write_data(data)
                except TransportTerminated:
                    dead.append(writer.transport)
        finally:
            impl.release()
        for connection in dead:
            connection.close()  # rospy then drops it from the topic
        return True
