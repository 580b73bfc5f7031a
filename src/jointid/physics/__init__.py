"""Physics: beam elements, assembled structures, natural modes and FRF synthesis."""
