# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""QoS overrides of the node's publishers, as ROS 2 parameters name them.

``qos_overrides.<topic>.publisher.<policy>`` (for instance in a ``--params-file``) sets a
policy of the publisher of ``<topic>`` (its fully qualified name), for ``history``,
``depth``, ``reliability`` and ``durability``. rclpy declares such parameters only for
publishers created with ``qos_overriding_options``, and ignores every other override
silently; here an override that names a topic the node does not publish, an entity other
than a publisher or another policy is refused at start with the reason instead.

Only the publishers an override names get the options, so the node does not declare
parameters for thousands of per-body topics nobody tunes. Overrides are read at start, as
ROS reads them; a publisher created again (a scene reload) keeps the profile it got then.
Setting one at runtime is refused saying so (rclpy would refuse an undeclared one as
"Invalid access to undeclared parameter(s): []", its list of names consumed by the check).
"""
import re

from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.qos import QoSPolicyKind
from rclpy.qos_overriding_options import QoSOverridingOptions

from rigid_sim.core.text import shown
from rigid_sim.parameters import ParameterError

# History depth of every topic the node publishes or subscribes to, unless overridden here.
QUEUE_DEPTH = 10
POLICIES = {kind.name.lower(): kind for kind in (
    QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY,
    QoSPolicyKind.DURABILITY)}
NAME = re.compile(r'qos_overrides\.(?P<topic>/[^.]*)\.(?P<entity>[^.]+)\.(?P<policy>[^.]+)\Z')


class ReadAtStart(ParameterNotDeclaredException):
    """A QoS override set at runtime; rclpy's parameter service answers with ``str()``."""

    def __init__(self, names):
        Exception.__init__(self, f'{shown(names)}: QoS overrides are read at start only '
                                 '(--params-file or -p); restart the node to change them')


class QosOverrides:
    """The overrides given to ``node`` at start, applied as its publishers are created.

    Parameters
    ----------
    node : rclpy.node.Node
        Its overrides (``--params-file``, ``-p``) are read here.

    Raises
    ------
    rigid_sim.parameters.ParameterError
        For an override that is not ``qos_overrides.<topic>.publisher.<policy>`` with a
        policy above.
    """

    def __init__(self, node):
        self._node = node
        self._requested = {}   # fully qualified topic -> parameter names overriding it
        self._profiles = {}    # fully qualified topic -> QoSProfile it got at creation
        self._published = set()   # fully qualified topics of every publisher created
        self.starting = True   # overrides are declared while the node starts only
        node.add_pre_set_parameters_callback(self._refuse_undeclared)
        # rclpy keeps the overrides only in this attribute (parameters.declare reads it too).
        for name in node._parameter_overrides:
            if name.startswith('qos_overrides.'):
                self._requested.setdefault(self._topic(name), []).append(name)

    @staticmethod
    def _topic(name):
        match = NAME.match(name)
        if match is None or match['entity'] != 'publisher' or match['policy'] not in POLICIES:
            raise ParameterError(
                f'{name}: this node takes QoS overrides of its publishers only, as '
                f'qos_overrides.<fully qualified topic>.publisher.<policy> with a policy in '
                f'{sorted(POLICIES)}')
        return match['topic']

    def _refuse_undeclared(self, changes):
        """Raise ReadAtStart for a change of an undeclared QoS override; else pass all on.

        rclpy calls this before its own checks, as the first step of every set (not of a
        declaration); a declared override is read-only, and rclpy refuses it so.
        """
        names = [change.name for change in changes if change.name.startswith('qos_overrides.')
                 and not self._node.has_parameter(change.name)]
        if names:
            raise ReadAtStart(names)
        return changes

    def create_publisher(self, kind, topic, qos, **options):
        """``node.create_publisher``, honouring the overrides of ``topic``."""
        resolved = self._node.resolve_topic_name(topic)
        self._published.add(resolved)
        if resolved in self._profiles:
            return self._node.create_publisher(kind, topic, self._profiles[resolved], **options)
        if not (self.starting and resolved in self._requested):
            return self._node.create_publisher(kind, topic, qos, **options)
        publisher = self._node.create_publisher(
            kind, topic, qos, qos_overriding_options=QoSOverridingOptions(POLICIES.values()),
            **options)
        self._profiles[resolved] = publisher.qos_profile
        return publisher

    def finish_start(self):
        """Refuse overrides of topics the node does not publish (ParameterError); none from now."""
        self.starting = False
        unused = sorted(name for topic, names in self._requested.items()
                        if topic not in self._profiles for name in names)
        if unused:
            raise ParameterError(f'{unused}: the node publishes no such topic; it publishes '
                                 f'{sorted(self._published)}')
