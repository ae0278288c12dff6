"""Tells the plugin's GUI that an algorithm stopped for lack of a package, from whichever thread the
algorithm ran in (Processing runs algorithms in a background thread; the message bar lives in the main
thread, and a queued signal crosses over)."""
from qgis.PyQt.QtCore import QObject, pyqtSignal


class DependencyNotice(QObject):
    #: the pip requirements that are missing
    missing = pyqtSignal(list)


#: created on import, i.e. in the main thread, when the plugin loads
NOTICE = DependencyNotice()
