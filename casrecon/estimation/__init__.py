"""The fit: data preparation, collocation transcription, NLP assembly, Ipopt solve, covariance."""
