"""Two small systems between a diagram's ports and Drake's LCM systems: `ToMessage` makes a
port's value into an LCM message (for an `LcmPublisherSystem`), `FromMessage` reads one (from
an `LcmSubscriberSystem`) back into a port's value. What a value's message is, and back, is
a plain function (`robot_channels`). `add_publisher`, `add_subscriber` and `add_reader` wire
them, the same way on both sides of the boundary."""

from collections.abc import Callable

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    InputPort,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.lcm import LcmInterfaceSystem, LcmPublisherSystem, LcmSubscriberSystem

from s3o_drake.world.system_lifetime import weak_callback


class ToMessage(LeafSystem):
    """Makes its input into an LCM message of `message_type`, stamped with the time.

    `encode(value, t)` makes the message of the input's value at time t (s). The input is
    a vector of `size`, or, with `size` None, abstract of `model`'s type.

    Input ports:
        value: vector (size) or abstract (model).
    Output ports:
        message: abstract message_type.
    """

    def __init__(self, *, message_type: type, encode: Callable[[object, float], object],
                 size: int | None = None, model: object = None) -> None:
        super().__init__()
        self._encode = encode
        if size is not None:
            self._value = self.DeclareVectorInputPort("value", size)
        else:
            self._value = self.DeclareAbstractInputPort("value", AbstractValue.Make(model))
        self.DeclareAbstractOutputPort(
            "message", lambda: AbstractValue.Make(message_type()),
            weak_callback(self._calc_message),
            prerequisites_of_calc={self.time_ticket(), self._value.ticket()})

    def _calc_message(self, context: Context, output: AbstractValue) -> None:
        value = self._value.Eval(context)
        if isinstance(value, np.ndarray):
            value = value.copy()
        output.set_value(self._encode(value, context.get_time()))


class FromMessage(LeafSystem):
    """Reads an LCM message of `message_type` into a port's value.

    `decode(message)` gives the value, or None for a message that says nothing yet (the
    subscriber's empty message before the first one came), when the output is `initial`.
    The output is a vector of `size`, or, with `size` None, abstract of `initial`'s type.

    Input ports:
        message: abstract message_type.
    Output ports:
        value: vector (size) or abstract.
    """

    def __init__(self, *, message_type: type, decode: Callable[[object], object],
                 initial: object, size: int | None = None) -> None:
        super().__init__()
        self._decode = decode
        self._initial = initial
        self._message = self.DeclareAbstractInputPort("message",
                                                      AbstractValue.Make(message_type()))
        if size is not None:
            self.DeclareVectorOutputPort("value", size, weak_callback(self._calc_vector),
                                         prerequisites_of_calc={self._message.ticket()})
        else:
            self.DeclareAbstractOutputPort("value", lambda: AbstractValue.Make(initial),
                                           weak_callback(self._calc_abstract),
                                           prerequisites_of_calc={self._message.ticket()})

    def _value(self, context: Context) -> object:
        value = self._decode(self._message.Eval(context))
        return self._initial if value is None else value

    def _calc_vector(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(np.asarray(self._value(context), dtype=float))

    def _calc_abstract(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._value(context))


def add_publisher(builder: DiagramBuilder, *, lcm: LcmInterfaceSystem, channel: str,
                  message_type: type, encode: Callable[[object, float], object],
                  period: float, size: int | None = None, model: object = None) -> InputPort:
    """A `ToMessage` ("to_<channel>") and a publisher ("publish_<channel>") of `channel`
    every `period` s; the port whose value is published."""
    writer = builder.AddNamedSystem(f"to_{channel.lower()}", ToMessage(
        message_type=message_type, encode=encode, size=size, model=model))
    publisher = builder.AddNamedSystem(f"publish_{channel.lower()}", LcmPublisherSystem.Make(
        channel=channel, lcm_type=message_type, lcm=lcm, publish_period=period))
    builder.Connect(writer.get_output_port(), publisher.get_input_port())
    return writer.get_input_port()


def add_subscriber(builder: DiagramBuilder, *, lcm: LcmInterfaceSystem, channel: str,
                   message_type: type) -> OutputPort:
    """A subscriber of `channel` ("subscribe_<channel>"); its message's port."""
    return builder.AddNamedSystem(f"subscribe_{channel.lower()}", LcmSubscriberSystem.Make(
        channel=channel, lcm_type=message_type, lcm=lcm)).get_output_port()


def add_reader(builder: DiagramBuilder, message: OutputPort, *, name: str,
               message_type: type, decode: Callable[[object], object], initial: object,
               size: int | None = None) -> OutputPort:
    """A `FromMessage` named `name` on the subscriber's `message`; its value's port."""
    reader = builder.AddNamedSystem(name, FromMessage(
        message_type=message_type, decode=decode, initial=initial, size=size))
    builder.Connect(message, reader.get_input_port())
    return reader.get_output_port()
