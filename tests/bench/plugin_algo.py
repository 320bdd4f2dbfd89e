"""An algorithm class that is not registered on import: the entry-point test registers it."""
from tests.bench.fakes import _Base


class PluginAlgo(_Base):
    pass
