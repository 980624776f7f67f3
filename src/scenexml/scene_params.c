/* Scene parameters (Mitsuba's -D name=value): attribute values in the scene
 * file may hold $name, replaced by the value given on the command line or
 * else by the scene's own <default name="..." value="..."/>. The
 * substitution happens on the parsed document, before anything is read
 * from it, so every attribute of every element takes parameters alike. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scenexml/scene_xml_internal.h"

static int valid_name(const char *s, size_t len)
{
    if (len == 0 || len >= SCENE_PARAM_NAME || !(isalpha((unsigned char)s[0]) || s[0] == '_'))
        return 0;
    for (size_t i = 1; i < len; i++)
        if (!(isalnum((unsigned char)s[i]) || s[i] == '_'))
            return 0;
    return 1;
}

static int params_find(const scene_params *p, const char *name, size_t len)
{
    for (int i = 0; i < p->n; i++)
        if (strlen(p->name[i]) == len && !strncmp(p->name[i], name, len))
            return i;
    return -1;
}

static int params_set(scene_params *p, const char *name, size_t len, const char *value, rr_error *err)
{
    if (!valid_name(name, len))
        return rr_fail(err, "parameter name '%.*s' must be a letter or _ followed by letters, digits or _ "
                            "(at most %d)", (int)len, name, SCENE_PARAM_NAME - 1);
    if (strlen(value) >= SCENE_PARAM_VALUE)
        return rr_fail(err, "parameter '%.*s': its value is %zu characters long: at most %d are read", (int)len, name,
                       strlen(value), SCENE_PARAM_VALUE - 1);
    int i = params_find(p, name, len);
    if (i < 0) {
        if (p->n == SCENE_MAX_PARAMS)
            return rr_fail(err, "more than %d parameters", SCENE_MAX_PARAMS);
        i = p->n++;
        snprintf(p->name[i], sizeof p->name[i], "%.*s", (int)len, name);
        p->used[i] = 0;
    }
    snprintf(p->value[i], sizeof p->value[i], "%s", value);
    return 0;
}

int scene_params_add(scene_params *p, const char *assignment, rr_error *err)
{
    const char *eq = strchr(assignment, '=');
    if (!eq)
        return rr_fail(err, "-D %s: expected name=value", assignment);
    return params_set(p, assignment, (size_t)(eq - assignment), eq + 1, err);
}

/* <default name="..." value="..."/>: fills in parameters not given; the
 * elements are removed from the document. */
static int read_defaults(xml_ctx *c, xmlNodePtr root, scene_params *p, int given)
{
    static const char *const ok[] = {"name", "value", NULL};
    xmlNodePtr next;
    for (xmlNodePtr k = root->children; k; k = next) {
        next = k->next;
        if (!xml_is_element(k) || strcmp(xml_elname(k), "default"))
            continue;
        char name[SCENE_PARAM_NAME + 8], value[SCENE_PARAM_VALUE + 8];
        if (xml_check_attributes(c, k, ok))
            return -1;
        int has_name = xml_attr_text(c, k, "name", name, sizeof name);
        int has_value = has_name < 0 ? -1 : xml_attr_text(c, k, "value", value, sizeof value);
        if (has_name < 0 || has_value < 0) /* too long: the error names it */
            return -1;
        if (!has_name || !has_value)
            return xml_fail(c, k, "<default> needs name and value");
        int i = params_find(p, name, strlen(name));
        rr_error sub;
        if ((i < 0 || i >= given) && params_set(p, name, strlen(name), value, &sub))
            return xml_fail(c, k, "%s", sub.msg);
        xmlUnlinkNode(k);
        xmlFreeNode(k);
    }
    return 0;
}

/* Replaces every $name in one attribute value; the result grows as needed
 * (the reader of each attribute refuses what it cannot hold, naming it). */
static int substitute(xml_ctx *c, xmlNodePtr n, xmlAttrPtr a, scene_params *p)
{
    xmlChar *v = xmlNodeListGetString(n->doc, a->children, 1);
    if (!v)
        return 0;
    const char *s = (const char *)v;
    if (!strchr(s, '$')) {
        xmlFree(v);
        return 0;
    }
    char *out = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&out, &len);
    int rc = f ? 0 : xml_fail(c, n, "out of memory");
    for (size_t i = 0; s[i] && !rc;) {
        size_t j = i + 1;
        while (s[i] == '$' && (isalnum((unsigned char)s[j]) || s[j] == '_'))
            j++;
        int k = s[i] == '$' ? params_find(p, s + i + 1, j - i - 1) : -1;
        if (s[i] == '$' && k < 0)
            rc = xml_fail(c, n, "attribute '%s': unknown parameter '$%.*s' (give -D %.*s=... or a <default>)",
                          (const char *)a->name, (int)(j - i - 1), s + i + 1, (int)(j - i - 1), s + i + 1);
        else if (k >= 0)
            fputs(p->value[k], f), p->used[k] = 1;
        else
            fputc(s[i], f);
        i = k >= 0 ? j : i + 1;
    }
    if (f && fclose(f) && !rc)
        rc = xml_fail(c, n, "out of memory");
    if (!rc)
        xmlSetProp(n, a->name, (const xmlChar *)out);
    free(out);
    xmlFree(v);
    return rc;
}

static int substitute_tree(xml_ctx *c, xmlNodePtr n, scene_params *p)
{
    for (; n; n = n->next) {
        if (!xml_is_element(n))
            continue;
        for (xmlAttrPtr a = n->properties; a; a = a->next)
            if (substitute(c, n, a, p))
                return -1;
        if (substitute_tree(c, n->children, p))
            return -1;
    }
    return 0;
}

int xml_apply_parameters(xml_ctx *c, xmlNodePtr root, const scene_params *given, scene_params *applied)
{
    *applied = given ? *given : (scene_params){0};
    int ngiven = applied->n;
    if (read_defaults(c, root, applied, ngiven) || substitute_tree(c, root, applied))
        return -1;
    for (int i = 0; i < ngiven; i++)
        if (!applied->used[i])
            rr_warn(&c->sc->warnings, "%s: parameter '%s' (-D) is not used by the scene", c->name, applied->name[i]);
    return 0;
}
