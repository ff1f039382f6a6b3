"""The package's publisher (tcpros_out.py: the bridge's topics, /clock) on real rospy topics and real
TCP sockets on loopback: a subscriber at the other end of a socket that reads, reads late or is gone.
No ROS master is needed: a connection is handed to the topic as rospy's TCPROS server hands it one.
rospy itself stays as installed (a test below holds that).
"""

import socket
import struct
import threading
import time

import pytest
from rospy.impl.tcpros_base import TCPROSTransport
from rospy.impl.tcpros_pubsub import TCPROSPub
from std_msgs.msg import String

from offboard_py import tcpros_out

BOUND_S = 5.0


def _connect(publisher, topic, buffer_bytes=None):
    """A TCP connection on loopback, its publisher end given to `publisher` as rospy's server gives
    it; returns the subscriber's end and the publisher's transport. `buffer_bytes` caps both ends'
    kernel buffers (else the system's autotuning sizes them)."""
    with socket.socket() as server:
        server.bind(('127.0.0.1', 0))
        server.listen(1)
        reader = socket.socket()
        reader.settimeout(BOUND_S)
        if buffer_bytes:
            reader.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, buffer_bytes)  # before the window is offered
        reader.connect(server.getsockname())
        sock, _ = server.accept()
    if buffer_bytes:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, buffer_bytes)
    transport = TCPROSTransport(TCPROSPub(topic, String), topic)
    transport.set_socket(sock, '/reader')
    publisher.rospy_publisher.impl.add_connection(transport)  # what rospy's TCPROS server does
    return reader, transport


class _Subscriber:
    """The subscriber's end: TCPROS frames (4-byte length, then the message) read as Strings."""

    def __init__(self, sock):
        self.sock = sock
        self.buffer = b''

    def read(self, count):
        messages = []
        while True:
            while len(messages) < count and len(self.buffer) >= 4:
                size = struct.unpack('<I', self.buffer[:4])[0]
                if len(self.buffer) < 4 + size:
                    break
                messages.append(String().deserialize(self.buffer[4:4 + size]).data)
                self.buffer = self.buffer[4 + size:]
            if len(messages) == count:
                return messages
            chunk = self.sock.recv(1 << 20)  # the socket's timeout bounds the wait
            assert chunk, 'the publisher closed the connection after %d of %d messages' % (len(messages), count)
            self.buffer += chunk


def _publish(publisher, text):
    publisher.publish(String(text))


@pytest.fixture
def publisher(request):
    topic = '/tcpros_out_%s' % request.node.name
    latch = 'latch' in request.node.name
    made = tcpros_out.Publisher(topic, String, 3, tcpros_out.Flusher(poll_ms=10), latch=latch)
    yield made
    made.unregister()


def test_rospy_stays_as_installed(publisher):
    """Nothing of rospy is replaced: its topic wraps no connection and keeps its own methods."""
    impl = publisher.rospy_publisher.impl
    assert impl.queue_size is None
    assert 'add_connection' not in vars(impl) and 'publish' not in vars(impl)
    assert type(impl).add_connection.__module__ == 'rospy.topics'
    reader, _transport = _connect(publisher, publisher.resolved_name)
    with reader:
        assert type(impl.connections[0]).__name__ == 'TCPROSTransport'


def test_messages_arrive_whole_and_in_order_through_the_unblocked_writer(publisher):
    reader, transport = _connect(publisher, publisher.resolved_name)
    with reader:
        assert isinstance(publisher.writers()[0], tcpros_out.UnblockedConnection)
        for i in range(20):
            _publish(publisher, 'message %d' % i)
        assert _Subscriber(reader).read(20) == ['message %d' % i for i in range(20)]
        assert transport.stat_num_msg == 20


def test_latched_message_reaches_a_late_subscriber_latch(publisher):
    _publish(publisher, 'latched')
    reader, _transport = _connect(publisher, publisher.resolved_name)
    with reader:
        assert _Subscriber(reader).read(1) == ['latched']


def test_a_subscriber_that_stops_reading_never_blocks_the_publisher(publisher):
    """rospy's queueless publish would block in sendall once the socket's buffers fill; here each
    publish returns at once and the subscriber gets, when it reads again, whole messages in order,
    the newest ones kept (queue_size 3, the oldest dropped first), none cut."""
    reader, _transport = _connect(publisher, publisher.resolved_name, buffer_bytes=1 << 16)
    with reader:
        big = 'x' * 1000000
        count = 20  # 20 MB: far more than the two 64 KB socket buffers hold
        done = threading.Event()
        took = []

        def publish_all():
            for i in range(count):
                start = time.monotonic()
                _publish(publisher, '%d %s' % (i, big))
                took.append(time.monotonic() - start)
            done.set()
        threading.Thread(target=publish_all, daemon=True).start()
        assert done.wait(BOUND_S), 'publish blocked on a subscriber that does not read (%d of %d out)' % (
            len(took), count)
        connection = publisher.writers()[0]
        assert connection.dropped > 0, 'nothing was dropped although the subscriber read nothing'
        subscriber = _Subscriber(reader)
        received = []
        deadline = time.monotonic() + BOUND_S
        while not received or not received[-1].startswith('%d ' % (count - 1)):
            assert time.monotonic() < deadline, 'the newest message never arrived; got %d messages, last %r' % (
                len(received), received[-1][:12] if received else None)
            received += subscriber.read(1)
        numbers = [int(text.split(' ', 1)[0]) for text in received]
        assert numbers == sorted(numbers), 'messages out of order: %s' % numbers
        assert all(text.endswith(big) for text in received), 'a message arrived cut'
        assert len(received) + connection.dropped == count
        assert max(took) < 1.0, 'one publish took %.3f s' % max(took)


def test_a_subscriber_that_is_gone_is_dropped_from_the_topic(publisher):
    reader, transport = _connect(publisher, publisher.resolved_name)
    reader.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack('ii', 1, 0))  # close with a reset
    reader.close()
    deadline = time.monotonic() + BOUND_S
    while publisher.rospy_publisher.impl.connections:
        assert time.monotonic() < deadline, 'the dead connection is still on the topic'
        _publish(publisher, 'to nobody')  # must not raise
        time.sleep(0.01)
    assert transport.done


def test_a_socket_with_a_timeout_gets_rospys_queue(publisher):
    """Python waits for room before a send on a socket with a timeout, MSG_DONTWAIT or not: such a
    connection is left to rospy's own writer thread, which may wait."""
    with socket.socket() as server:
        server.bind(('127.0.0.1', 0))
        server.listen(1)
        reader = socket.create_connection(server.getsockname(), timeout=BOUND_S)
        sock, _ = server.accept()
    sock.settimeout(1.0)
    transport = TCPROSTransport(TCPROSPub(publisher.resolved_name, String), publisher.resolved_name)
    transport.set_socket(sock, '/reader')
    publisher.rospy_publisher.impl.add_connection(transport)
    with reader:
        assert type(publisher.writers()[0]).__name__ == 'QueuedConnection'
        _publish(publisher, 'through rospy')
        assert _Subscriber(reader).read(1) == ['through rospy']


def test_no_module_assigns_over_a_library_method():
    """No source of the package replaces a method of rospy's or pymavlink's (as bridge/tcpros_out.py once
    replaced a rospy topic's add_connection, and dialect.py pymavlink's _pack): an assignment to one of
    their method names on any object is refused here, naming the line."""
    import pathlib
    import re
    methods = ('add_connection', 'remove_connection', 'publish', 'write_data', '_pack', 'pack', 'check_signature',
               'decode', 'parse_char', 'parse_buffer', 'send', 'recv_msg')
    assignment = re.compile(r'\.(%s)\s*=(?!=)' % '|'.join(methods))
    root = pathlib.Path(__file__).resolve().parents[2] / 'src' / 'offboard_py'
    found = ['%s:%d: %s' % (path.relative_to(root), number, line.strip())
             for path in sorted(root.rglob('*.py'))
             for number, line in enumerate(path.read_text().splitlines(), 1) if assignment.search(line)]
    assert not found, 'a library method replaced:\n' + '\n'.join(found)
