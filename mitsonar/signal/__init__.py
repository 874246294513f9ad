"""Signals: the band model shared by synthesis and reception, echo synthesis (paths -> recordings),
the receiver (delay-and-sum, matched filter, envelope, time of arrival, depth) and OFDM codes and
schedules."""
