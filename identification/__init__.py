"""Car identification: which cars passed each reader, in which order (spec: identification.md).

Pure algorithms (numpy and the standard library only). Decoders accept exactly the payload
fields of the protocol's device events; simulators (``identification.simulate``) produce such
payloads and are kept apart from the decoders.

Rules — ``identification.rules`` (one documented place for what a car number needs)
    ``RULES = IdentificationRules(zones_per_axle=8, adc_min=0, adc_max=4095,
    min_agreeing_axles=2, min_agreeing_reads=2)``: the fleet's wheel-code length, the
    wheel-mark reader's ADC range, the agreeing axles and the agreeing IR reads a number needs.
    Weak or impossible evidence gives no number and a reason (a person must look).
    ``agreed_number(reads) -> (number | None, reason)``: the rule of ``ir_id`` and ``ir_pulses``.

Wheel marks — ``identification.wheel_marks`` (events ``wheel_marks``, ``wheel_marks_written``)
    ``simulate_marking(detections, *, axles=4) -> MarkingResult``
        ``.state`` ("marked" / "partial" / "lost"), ``.written`` (bool per axle), ``.faults``.
        Feed it a ``wheel_marks_written`` event's ``detections``.
    ``ReadingSection(*, axles=4, baseline_length=8)``
        ``.sample(code)``, ``.edge(sensor, value=None) -> WheelReading | None``, ``.feed(edges)``;
        ``WheelReading.as_event()`` gives a ``wheel_marks`` payload.
    ``smooth_baseline(samples) -> float``
        ``a0`` of the last five samples, ``(-3, 12, 17, 12, -3) / 35``.
    ``decode_passage(baseline, axles, *, direction, bits_per_axle=None, layout="duplicate")``
        ``-> WheelDecode`` with ``.code`` (int or None), ``.reason``, ``.readable_axles``,
        ``.margin``. ``bits_per_axle`` defaults to the fleet's ``RULES.zones_per_axle`` (never
        the payload's: 7 zones of an 8-bit code would name another car); ADC codes outside
        the reader's range and bits fewer than 2 axles agree on give no code. The
        protocol's example event (direction 1, eight zones per axle) decodes to code 178
        (0b10110010) on all four axles, margin ≈ 0.97.

Infrared time-pulse — ``identification.time_pulse`` (event ``ir_pulses``)
    ``decode_passage(reply_times_us, *, query_period_us, reflection_window_us,
    query_times_us=None) -> TimePulseDecode`` with ``.car_number`` (int or None), ``.reads``,
    ``.reason``; a number needs ``RULES.min_agreeing_reads`` agreeing reads, as ``ir_id``.
    The protocol's example event decodes to reads [118, 118] → car 118.
    ``detection_probabilities(*, amplitude, threshold, noise_density, pulse_width, gain=1.0)``
    ``-> Detection(p_detect, p_false)``.
    ``plan_reader(*, speed_kmh, query_period_us, zone_length_m=None, range_m=None,
    beam_angle_deg=None, reads_required=3, car_number=None, baud=None) -> ReaderPlan``.

Manchester-II — ``identification.manchester`` (event ``ir_manchester``)
    ``encode_frame(car_number, *, convention="ieee") -> list[int]`` (one level per half-bit).
    ``decode_passage(samples, *, samples_per_bit, convention="ieee") -> ManchesterDecode``
    with ``.car_number``, ``.frames_ok``, ``.frames_bad``, ``.reason``. The protocol's
    16-sample example holds two bits and no frame: car_number None, "no frame found".
    Clock recovery and bit decoding live in ``identification.biphase.recover_bits``.

EM4100/EM4102 RFID traces — ``identification.em4100`` (no event, no CLI: the spec asks for
none; a check of the clock recovery on real recordings)
    ``decode_trace(load_pm3(path)) -> EM4100Decode`` with ``.tag_id`` (10 hex digits or None),
    ``.frames_ok``, ``.reason``, ``.arrow``. E.g. ``python -c "from identification.em4100 import
    decode_trace, load_pm3; print(decode_trace(load_pm3('…/lf_EM4102-fob.pm3')))"`` →
    ``tag_id='0400193cbe'``. An ID needs every parity-valid frame to agree at one bit phase and
    the trace to run forward in time (a reversed trace gives None); an empty trace raises a
    ``ValueError`` naming it.

Consists — ``identification.consist`` (event ``ir_id`` and the run's evidence)
    ``majority_number(reads: Sequence[int]) -> int | None``
        Strict majority of repeated IR reads, else None (the service's ``ir_id`` also needs
        ``RULES.min_agreeing_reads`` agreeing reads: ``identification.rules.agreed_number``).
    ``assemble_consist(reads, *, wheel_codes, ir_numbers, direction=None) -> Consist``
        ``reads``: ``CarRead(wheel_code, ir_number)`` per car in passing order (pair two
        readers' lists with ``combine_reads``); ``wheel_codes`` / ``ir_numbers`` map the
        registry's codes to car ids. Unregistered reads stay as unknown positions; a
        wheel/IR disagreement is a ``conflict`` entry. ``Consist.car_ids`` → list of id/None.
    ``compare_consists(departure, arrival) -> ConsistComparison``
        ``.status`` "identical" / "missing" / "unknown", ``.missing`` [(position, car id)],
        ``.unknown_positions``, ``.aligned`` [(departure car, arrival car, mark)] with mark
        "same" / "missing" / "unknown" / "extra", ``.reason`` (e.g. "arrival consist lacks
        cars 0412, 0413 (positions 11–12)").
    ``axle_sum(cars, axles_per_car, *, default_axles=None) -> int | None`` and
    ``compare_axles(departure, arrival) -> AxleComparison`` ("equal"/"fewer"/"more"/"unknown").

EOT radio packets — ``identification.eot`` (FM-demodulated audio; event ``eot_status``)
    ``decode_wav(path)`` / ``decode_audio(samples, rate)`` -> list of ``EotPacket`` with
    ``.unit_address``, ``.pressure_psig``, ``.battery_charge`` (0–127), ``.battery_condition``,
    ``.message_type``, ``.motion``, ``.marker_light``, the other flags, ``.bits``, ``.at_s``.
    Only BCH-valid packets. ``parse_packet(bits)`` / ``bch_valid(bits)`` check a 74-bit
    string (the service checks ``eot_status.bits`` with them). Channel impairments and an
    FFSK modulator for tests: ``identification.eot_channel``.

Simulators — ``identification.simulate`` (tests, benchmark, demo)
    ``ir_pulses_passage(car_number, *, speed_kmh, rng, ...)`` → ``{"query_period_us",
    "reflection_window_us", "reply_times_us"}``;
    ``manchester_passage(car_number, *, samples_per_bit=8, rng, ...)`` →
    ``{"samples_per_bit", "samples"}``;
    ``wheel_mark_passage(code, *, direction, rng, ...)`` → ``{"direction", "baseline",
    "axles"}``; ``reading_edges(passage, ...)`` and ``marking_detections(head_positions_m)``
    for the reading and marking sections.
"""

from identification import consist, eot, manchester, rules, simulate, time_pulse, wheel_marks

__all__ = ["consist", "eot", "manchester", "rules", "simulate", "time_pulse", "wheel_marks"]
