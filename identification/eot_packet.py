"""EOT packet layer: the 74-bit frame, its BCH check, its fields (spec: identification.md, EOT).

A packet is 74 bits: frame sync ``11100010010`` (bits 0–10), battery condition 13–14, message
type 15–17, unit address 18–34, brake-pipe pressure (psig) 35–41, battery charge 42–48, flags
49–55, BCH check bits 56–73; multi-bit fields least significant bit first. The audio side
(FFSK receiver) is :mod:`identification.eot`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["FRAME_SYNC", "PACKET_BITS", "EotPacket", "bch_valid", "parse_packet"]

FRAME_SYNC = "11100010010"
PACKET_BITS = 74
_GENERATOR = 0b1111001101000001111  # degree 18
_CHECK_XOR = 0b101011011101110000
_CHECK_BITS = 18


@dataclass(frozen=True)
class EotPacket:
    """One BCH-valid EOT packet.

    Attributes
    ----------
    unit_address
        The EOT unit's 17-bit address (bits 18–34).
    pressure_psig
        Brake-pipe pressure at the rear, psig, 0–127 (bits 35–41).
    battery_charge
        Battery charge, raw 7-bit value 0–127 (127 = full; bits 42–48).
    battery_condition
        Two-bit battery condition (bits 13–14): 3 OK, 2 low, 1 very low, 0 not monitored.
    message_type
        Three-bit message type (bits 15–17).
    motion
        The unit senses motion (flag bit 53).
    marker_light
        The rear marker light is on (flag bit 55).
    valve_circuit, confirmation, turbine, marker_battery
        The other flag bits (50, 51, 52, 54).
    bits
        The 74 bits as received, "0"/"1".
    at_s
        Start of the frame sync in the audio, seconds (not part of equality).
    """

    unit_address: int
    pressure_psig: int
    battery_charge: int
    battery_condition: int
    message_type: int
    motion: bool
    marker_light: bool
    valve_circuit: bool
    confirmation: bool
    turbine: bool
    marker_battery: bool
    bits: str
    at_s: float = field(default=0.0, compare=False)

    def to_dict(self) -> dict[str, object]:
        """The packet as plain JSON-ready values."""
        return {
            "unit_address": self.unit_address,
            "pressure_psig": self.pressure_psig,
            "battery_charge": self.battery_charge,
            "battery_condition": self.battery_condition,
            "message_type": self.message_type,
            "motion": self.motion,
            "marker_light": self.marker_light,
            "valve_circuit": self.valve_circuit,
            "confirmation": self.confirmation,
            "turbine": self.turbine,
            "marker_battery": self.marker_battery,
            "bits": self.bits,
            "at_s": round(self.at_s, 4),
        }


def _field(bits: str, first: int, last: int) -> int:
    """Bits ``first``..``last`` inclusive, sent least significant bit first."""
    return int(bits[first : last + 1][::-1], 2)


def _bch_remainder(data: int) -> int:
    """``data · x^18 mod g(x)`` over GF(2)."""
    value = data << _CHECK_BITS
    for shift in range(value.bit_length() - 1, _CHECK_BITS - 1, -1):
        if value >> shift & 1:
            value ^= _GENERATOR << (shift - _CHECK_BITS)
    return value


def bch_valid(bits: str) -> bool:
    """Whether a 74-bit string is a packet: frame sync present and BCH check bits right."""
    if len(bits) != PACKET_BITS or set(bits) - {"0", "1"} or not bits.startswith(FRAME_SYNC):
        return False
    data = int(bits[11:56][::-1], 2)
    return _bch_remainder(data) ^ _CHECK_XOR == int(bits[56:74], 2)


def parse_packet(bits: str, *, at_s: float = 0.0) -> EotPacket:
    """The fields of a 74-bit packet; ``ValueError`` if it is not one (sync or BCH wrong)."""
    if not bch_valid(bits):
        raise ValueError("not an EOT packet: 74 bits with frame sync and a valid BCH check")
    return EotPacket(
        unit_address=_field(bits, 18, 34),
        pressure_psig=_field(bits, 35, 41),
        battery_charge=_field(bits, 42, 48),
        battery_condition=_field(bits, 13, 14),
        message_type=_field(bits, 15, 17),
        motion=bits[53] == "1",
        marker_light=bits[55] == "1",
        valve_circuit=bits[50] == "1",
        confirmation=bits[51] == "1",
        turbine=bits[52] == "1",
        marker_battery=bits[54] == "1",
        bits=bits,
        at_s=at_s,
    )
