"""Errors of the hardware path.  Every message names the robot, the command and (when there is one) the reply,
because on a bench with three robots the first question after a failure is always "which one, doing what?"."""
from __future__ import annotations


class HardwareError(RuntimeError):
    """Base class: something went wrong talking to a robot."""

    def __init__(self, robot: str, command: str, message: str, reply: str | None = None) -> None:
        self.robot = robot
        self.command = command
        self.reply = reply
        text = f"robot {robot!r}, command {command!r}"
        if reply is not None:
            text += f", reply {reply!r}"
        super().__init__(f"{text}: {message}")


class ProtocolError(HardwareError, ValueError):
    """A reply that is malformed, unexpected (wrong letter, wrong field count, not a number) or the robot's
    error marker ``$``.  A ValueError too, so callers that validate input catch it naturally."""


class LinkError(HardwareError):
    """The link itself failed: the port cannot be opened, the connection dropped and could not be reopened."""


class RobotTimeout(LinkError):
    """The robot did not answer within the timeout, on every attempt the retry policy allows."""
