# filled by the probe work
