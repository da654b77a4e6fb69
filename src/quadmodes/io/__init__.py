"""Output files: ParaView VTU/PVD, PNG pictures and plots, and the atomic-write helper."""
