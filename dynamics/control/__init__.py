"""Control: the torque sources of :func:`dynamics.simulate` and the passive joint torques, one module per
concern.  Users import them from :mod:`dynamics.torques`, their public face; the core evaluates them
(``core/control/``: the sources, the operational-space controller, the passive torques and their derivatives).

==========================  ======================================================================================
:mod:`.sources`             the user-facing classes (:class:`~.sources.PD`, ...) and the checked ``Source``
:mod:`.validation`          ``make_source``: the user's argument checked and turned into a ``Source``
:mod:`.passive`             damping, friction and limit springs (the ``Passive`` record)
:mod:`.registry`            Python-callable torques, called back by the core with the GIL taken
==========================  ======================================================================================
"""
