"""QGIS expressions checked before a run, as the callables the core takes (attributes dict → value).

A height expression with a syntax error, a field the layer lacks, or one that fails on the first
feature is refused up front with the error named, instead of silently giving every building the
default. Errors on later features are counted (``CheckedExpression.failures``) for a warning.
Used by wit:extrudebuildings and the chain (one place for both).
"""
from __future__ import annotations

from typing import Any

from qgis.core import (
    QgsExpression,
    QgsExpressionContext,
    QgsExpressionContextUtils,
    QgsFeature,
    QgsFeatureRequest,
    QgsProcessingException,
)

from .translation import tr


class CheckedExpression:
    """A parsed, checked expression evaluated on attribute dicts; counts evaluation errors."""

    def __init__(self, expression: QgsExpression, context: QgsExpressionContext, fields):
        self.text = expression.expression()
        self._expression, self._context, self._fields = expression, context, fields
        self.failures = 0
        self.first_error = ""

    def __call__(self, attributes: dict) -> Any:
        feature = QgsFeature(self._fields)
        for name, value in attributes.items():
            if self._fields.indexOf(name) >= 0:
                feature[name] = value
        self._context.setFeature(feature)
        value = self._expression.evaluate(self._context)
        if self._expression.hasEvalError():
            self.failures += 1
            self.first_error = self.first_error or self._expression.evalErrorString()
            return None
        return value

    def failure_warning(self) -> str | None:
        """The warning for features the expression failed on, or None."""
        if not self.failures:
            return None
        return tr("The expression {expression} failed on {count} feature(s) (e.g. {error}); "
                  "the next rule was used for them.").format(expression=self.text, count=self.failures,
                                                             error=self.first_error)


def checked_expression(algorithm, parameters: dict, name: str, layer, context) -> CheckedExpression | None:
    """The expression parameter ``name`` parsed and tried on ``layer``'s first feature; None when empty.

    Raises ``QgsProcessingException`` naming the parameter and the error for a syntax error, a
    field the layer does not have, or an evaluation error on the first feature. The text is read
    with ``parameterAsString``: QGIS 3.22's ``parameterAsExpression`` returns '' for an expression
    with a syntax error, which is how such an expression used to be ignored.
    """
    text = algorithm.parameterAsString(parameters, name, context).strip()
    if not text:
        return None
    label = algorithm.parameterDefinition(name).description()
    expression = QgsExpression(text)
    if expression.hasParserError():
        raise QgsProcessingException(tr("{label}: the expression {expression} has a syntax error: {error}").format(
            label=label, expression=text, error=expression.parserErrorString()))
    fields = layer.fields()
    unknown = sorted(name for name in expression.referencedColumns()
                     if name != QgsFeatureRequest.ALL_ATTRIBUTES and fields.lookupField(name) < 0)
    if unknown:
        raise QgsProcessingException(tr(
            "{label}: the expression {expression} uses the field(s) {unknown}, which the layer '{layer}' does "
            "not have; its fields are: {fields}.").format(
            label=label, expression=text, unknown=", ".join(unknown), layer=layer.name(),
            fields=", ".join(fields.names())))
    expression_context = QgsExpressionContext(context.expressionContext())  # a copy: scopes are owned
    expression_context.appendScope(QgsExpressionContextUtils.layerScope(layer))
    expression.prepare(expression_context)
    first = next(layer.getFeatures(QgsFeatureRequest().setLimit(1)), None)
    if first is not None:
        expression_context.setFeature(first)
        expression.evaluate(expression_context)
        if expression.hasEvalError():
            raise QgsProcessingException(tr(
                "{label}: the expression {expression} fails on the first feature of '{layer}': {error}").format(
                label=label, expression=text, layer=layer.name(), error=expression.evalErrorString()))
    return CheckedExpression(expression, expression_context, fields)
