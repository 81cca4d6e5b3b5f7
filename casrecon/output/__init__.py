"""Writers of results folders: they serialise what the estimation and analysis layers computed, nothing more."""
