"""The TCP server for sensor, control and clock clients: one handler per role."""

from navd.drivers.tcp.server import TcpServer
from navd.drivers.tcp.settings import TcpSettings

__all__ = ["TcpServer", "TcpSettings"]
